"""The documentation site in a real browser: every page opens without console errors,
every image loads, every internal link resolves (and its anchor exists), search finds
each scenario's page; screenshots of the home page and one scenario page are saved into
docs/images/site/ for the README."""

from __future__ import annotations

import urllib.error
import urllib.parse
import urllib.request
from dataclasses import dataclass, field

import pytest
from site_files import ROOT, SITE, site_pages

import flatland_ma
from flatland_ma.lifelong import list_streams

PAGES = site_pages()
SCREENSHOTS = ROOT / "docs" / "images" / "site"
SHOWN_SCENARIO = "fruits_poisons"

# Every image on the page, lazy ones included, loaded (or failed) before it is measured.
BROKEN_IMAGES_JS = """async () => {
    const images = [...document.images];
    images.forEach(img => { img.loading = "eager"; });
    await Promise.all(images.map(img => img.complete ? null :
        new Promise(done => { img.onload = done; img.onerror = done; })));
    return images.filter(img => img.naturalWidth === 0).map(img => img.src);
}"""
LINKS_JS = "() => [...document.querySelectorAll('a[href]')].map(a => a.href)"
IDS_JS = "() => [...document.querySelectorAll('[id]')].map(e => e.id)"


@dataclass
class Visit:
    errors: list[str] = field(default_factory=list)
    broken_images: list[str] = field(default_factory=list)
    links: list[str] = field(default_factory=list)
    ids: set[str] = field(default_factory=set)


@pytest.fixture(scope="session")
def visits(site_url, browser_context) -> dict[str, Visit]:
    """Every page opened once, with what the browser reported on it."""
    out = {}
    page = browser_context.new_page()
    current: list[Visit] = []

    def console(message):
        if message.type == "error":
            current[-1].errors.append(f"console: {message.text}")

    page.on("console", console)
    page.on("pageerror", lambda error: current[-1].errors.append(f"page error: {error}"))

    def failed(request):
        # a request still under way when the next page is opened (the favicon, on a busy
        # machine) is aborted by that navigation: not a fault of either page; a missing
        # file is a response (the HTTP status and broken images are checked)
        if request.failure != "net::ERR_ABORTED":
            current[-1].errors.append(f"request failed: {request.url} ({request.failure})")

    page.on("requestfailed", failed)
    for path in PAGES:
        visit = Visit()
        current.append(visit)
        response = page.goto(site_url + path, wait_until="load")
        if response is None or response.status != 200:
            visit.errors.append(f"HTTP {response.status if response else 'none'}")
        visit.broken_images = page.evaluate(BROKEN_IMAGES_JS)
        visit.links = page.evaluate(LINKS_JS)
        visit.ids = set(page.evaluate(IDS_JS))
        out[path] = visit
    page.close()
    return out


def test_the_site_has_every_catalogue_page_and_the_guides():
    pages = set(PAGES)
    expected = {f"catalogue/scenarios/{name}.html" for name in flatland_ma.list_scenarios()}
    expected |= {f"catalogue/streams/{name}.html" for name in list_streams()}
    expected |= {"catalogue/suites/society.html", "index.html", "search.html"}
    expected |= {f"{guide}.html" for guide in ("integrations", "lifelong", "performance")}
    expected |= {"results.html", "scenarios.html", "api/index.html", "tutorials/index.html"}
    expected |= {"concepts.html", "extending.html", "rendering.html", "studio.html", "cli.html"}
    expected |= {"api/extending.html"}
    assert expected <= pages, sorted(expected - pages)


def page_text(path: str) -> str:
    return (SITE / path).read_text(encoding="utf-8")


def test_the_api_pages_show_the_env_and_every_extension_base_but_no_internal_constant():
    text = "".join(page_text(p) for p in PAGES if p.startswith("api/"))
    shown = [
        "flatland_ma.envs.parallel.FlatlandParallelEnv",
        "flatland_ma.scenario.extensions.register",
        "flatland_ma.build.feasibility.check_scenario",
        "flatland_ma.sensors.sensor.Sensor",
        "flatland_ma.tasks.rule.Rule",
        "flatland_ma.tasks.rule.Step",
        "flatland_ma.agents.parts.Part",
        "flatland_ma.build.generators.Generator",
        "flatland_ma.build.layout.Layout",
        "flatland_ma.build.layout.WallPiece",
        "flatland_ma.world.contacts.ContactLog",
    ]
    assert [name for name in shown if f'id="{name}"' not in text] == []
    hidden = ["flatland_ma.policies.greedy.PATIENCE", "flatland_ma.envs.shards.STARTUP_SECONDS"]
    assert [name for name in hidden if f'id="{name}"' in text] == []


def test_the_command_line_page_has_every_command_and_option():
    from flatland_ma.cli import build_parser, subcommands

    text = page_text("cli.html")
    for name, parser in subcommands(build_parser()).items():
        assert f'id="flatland-ma-{name}"' in text, name
        for action in parser._actions:
            for flag in action.option_strings:
                assert flag in text, (name, flag)
    assert text.count("(default:") >= 40


def test_a_scenario_page_gives_sensor_values_camera_channels_state_and_colour_names():
    text = page_text("catalogue/scenarios/fruits_poisons.html")
    assert "rays=64, fov=120, range=300" in text and "Global state" in text
    assert "depth: <code" in text and "red, green, blue of the first thing" in text
    assert "orange" in text and "(1.0, 0.6" not in text
    channel = page_text("catalogue/scenarios/signal_rooms.html")
    assert "tokens=1, vocabulary=2" in channel


@pytest.mark.parametrize("name", flatland_ma.list_scenarios())
def test_every_scenario_page_shows_an_animation(name):
    assert ".gif" in page_text(f"catalogue/scenarios/{name}.html")


def test_the_animations_stay_small():
    animations = list((ROOT / "docs" / "images" / "animations").glob("*.gif"))
    assert sum(path.stat().st_size for path in animations) < 4_000_000


def test_the_catalogue_groups_scenarios_in_a_gallery():
    text = page_text("catalogue/index.html")
    for title in ("Foraging and navigation", "Bodies with parts", "Roles, teams", "Other senses"):
        assert title in text
    assert text.count('class="thumb"') == len(flatland_ma.list_scenarios())
    assert "flatland_ma/FruitsPoisons-v0" in text and "Discrete(3)" in text


TUTORIALS = [p for p in PAGES if p.startswith("tutorials/") and p != "tutorials/index.html"]


def test_the_tutorials_ran_when_the_site_was_built():
    assert len(TUTORIALS) >= 3
    for path in TUTORIALS:
        text = (SITE / path).read_text(encoding="utf-8")
        assert text.count('class="cell_output') >= 2, path
    training = (SITE / "tutorials" / "training.html").read_text(encoding="utf-8")
    assert "trained for 256 steps" in training


@pytest.mark.parametrize("path", PAGES)
def test_page_opens_without_console_errors(visits, path):
    assert visits[path].errors == []


@pytest.mark.parametrize("path", PAGES)
def test_every_image_of_the_page_loads(visits, path):
    assert visits[path].broken_images == []


def test_every_internal_link_resolves_and_its_anchor_exists(visits, site_url):
    targets: dict[str, set[str]] = {}
    for path, visit in visits.items():
        for link in visit.links:
            if link.startswith(site_url):
                address, _, anchor = link.partition("#")
                targets.setdefault(address, set()).add(anchor)
                continue
            assert not link.startswith("http://127.0.0.1"), f"{path}: {link}"
    assert len(targets) >= len(PAGES) // 2  # the crawl saw the site's navigation
    unresolved, missing_anchors = [], []
    for address, anchors in sorted(targets.items()):
        try:
            with urllib.request.urlopen(address, timeout=60) as response:
                status = response.status
        except urllib.error.HTTPError as err:
            status = err.code
        if status != 200:
            unresolved.append((address, status))
            continue
        relative = urllib.parse.unquote(address[len(site_url) :]) or "index.html"
        if relative.endswith("/"):
            relative += "index.html"
        page = visits.get(relative)
        if page is None:
            continue  # a file, not a page (an image, a source file)
        missing_anchors += [(relative, a) for a in sorted(anchors) if a and a not in page.ids]
    assert unresolved == []
    assert missing_anchors == []


@pytest.mark.parametrize("name", flatland_ma.list_scenarios())
def test_search_finds_the_scenario_page(site_url, browser_context, name):
    page = browser_context.new_page()
    errors = []
    page.on("pageerror", lambda error: errors.append(str(error)))
    try:
        page.goto(f"{site_url}search.html?q={name}", wait_until="load")
        page.wait_for_function(
            "() => (document.querySelector('#search-results .search-summary') || {}).innerText",
        )
        found = page.evaluate(
            "() => [...document.querySelectorAll('#search-results ul.search li a')]"
            ".map(a => a.getAttribute('href'))"
        )
    finally:
        page.close()
    assert errors == []
    wanted = f"catalogue/scenarios/{name}.html"
    assert any(href.split("?")[0].split("#")[0] == wanted for href in found), found


@pytest.mark.parametrize(
    "shot, path",
    [("home.png", "index.html"), ("scenario.png", f"catalogue/scenarios/{SHOWN_SCENARIO}.html")],
)
def test_screenshots_for_the_readme(site_url, browser_context, shot, path):
    page = browser_context.new_page()
    try:
        page.goto(site_url + path, wait_until="load")
        # The search tests leave their words highlighted in this profile's storage.
        page.evaluate("() => { localStorage.clear(); sessionStorage.clear(); }")
        page.goto(site_url + path, wait_until="load")
        page.evaluate(BROKEN_IMAGES_JS)
        SCREENSHOTS.mkdir(parents=True, exist_ok=True)
        page.screenshot(path=str(SCREENSHOTS / shot))
        title = page.title()
    finally:
        page.close()
    assert (SCREENSHOTS / shot).stat().st_size > 10_000
    assert (SITE / path).is_file() and title
