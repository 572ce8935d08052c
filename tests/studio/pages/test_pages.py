"""The studio's pages in headless Chromium: the gallery, the editor (preview and located
errors), play at the keyboard, watch and its GIF. Every test also fails on a console error
(see conftest.py). Waits are bounded by what the page shows (steps), not by time."""

from __future__ import annotations

import hashlib
from pathlib import Path

from PIL import Image

from flatland_ma.scenario.loader import list_scenarios

SHOTS = Path(__file__).resolve().parents[3] / "docs" / "images" / "studio"
EATING_SEED = 1
"""fruits_poisons at this seed: going straight ahead eats a fruit within 7 steps."""


def picture_digest(page, selector: str) -> str:
    """A digest of the pixels an <img> shows (drawn into a canvas in the page)."""
    data = page.evaluate(
        """(selector) => {
            const img = document.querySelector(selector);
            const canvas = document.createElement("canvas");
            canvas.width = img.naturalWidth; canvas.height = img.naturalHeight;
            canvas.getContext("2d").drawImage(img, 0, 0);
            return canvas.toDataURL("image/png");
        }""",
        selector,
    )
    return hashlib.sha256(data.encode()).hexdigest()


def open_editor(page, ref: str) -> None:
    page.goto(page.studio_url + f"#/editor?ref={ref}")
    page.wait_for_function(
        "() => { const i = document.getElementById('preview'); "
        "return i && i.complete && i.naturalWidth > 0; }"
    )


def replace_text(page, old: str, new: str) -> None:
    page.evaluate(
        """([old, neu]) => {
            const view = window.studioEditor;
            const text = view.state.doc.toString();
            const at = text.indexOf(old);
            view.dispatch({changes: {from: at, to: at + old.length, insert: neu}});
        }""",
        [old, new],
    )


def test_the_gallery_shows_every_shipped_scenario(page):
    page.goto(page.studio_url + "#/gallery")
    page.wait_for_selector("#gallery .card")
    refs = page.eval_on_selector_all("#gallery .card", "cards => cards.map(c => c.dataset.ref)")
    assert set(list_scenarios()) <= set(refs)
    assert "0:my_room.yaml" in refs
    card = page.locator('.card[data-ref="fruits_poisons"]')
    assert "flatland_ma/FruitsPoisons-v0" in card.inner_text()
    card.locator("img").scroll_into_view_if_needed()
    page.wait_for_function(
        "() => document.querySelector('.card[data-ref=\"fruits_poisons\"] img').naturalWidth > 0"
    )


def test_changing_n_agents_in_the_editor_changes_the_preview(page):
    open_editor(page, "0:my_room.yaml")
    before = picture_digest(page, "#preview")
    first_src = page.get_attribute("#preview", "src")
    replace_text(page, "n_agents: 1", "n_agents: 3")
    page.wait_for_function(
        "(src) => { const i = document.getElementById('preview'); "
        "return i.src !== src && i.complete && i.naturalWidth > 0; }",
        arg=first_src,
    )
    assert picture_digest(page, "#preview") != before
    second_src = page.get_attribute("#preview", "src")
    page.click("#seed-up")
    page.wait_for_function(
        "(src) => document.getElementById('preview').src !== src", arg=second_src
    )
    assert page.get_attribute("#preview", "data-seed") == "1"


def test_a_wrong_key_shows_its_error_at_its_line(page):
    open_editor(page, "fruits_poisons")
    text = page.evaluate("() => window.studioEditor.state.doc.toString()")
    line = text.splitlines().index("n_agents: 1") + 1
    replace_text(page, "n_agents: 1", "n_agnets: 1")
    problem = page.wait_for_selector(f'.problem[data-line="{line}"]')
    assert "n_agnets" in problem.inner_text() and "unknown key" in problem.inner_text()
    marked = page.wait_for_selector(".cm-line:has(.cm-lintRange-error)")
    assert "n_agnets" in marked.inner_text()
    gutter_markers = page.locator(".cm-gutter-lint .cm-lint-marker-error")
    assert gutter_markers.count() == 1


def test_in_play_an_arrow_key_moves_the_agent_and_a_fruit_raises_the_score(page):
    page.goto(page.studio_url + f"#/play?ref=fruits_poisons&seed={EATING_SEED}")
    page.wait_for_selector("#step[data-step='0']")
    page.wait_for_function("() => document.getElementById('frame').naturalWidth > 0")
    before = picture_digest(page, "#frame")
    page.click("#frame")
    page.keyboard.down("ArrowUp")
    page.wait_for_function(
        "() => { const s = document.getElementById('score-value'); "
        "const t = document.getElementById('step'); "
        "return Number(s.dataset.score) > 0 || Number(t.dataset.step) > 40; }"
    )
    page.keyboard.up("ArrowUp")
    score = float(page.get_attribute("#score-value", "data-score") or "0")
    assert score >= 10
    assert int(page.get_attribute("#step", "data-step") or "0") >= 1
    assert picture_digest(page, "#frame") != before
    assert "up: forward" in page.inner_text("#keys")


def test_watch_runs_and_its_gif_downloads_and_decodes(page, tmp_path):
    page.goto(page.studio_url + "#/watch?ref=fruits_poisons_multi&seed=2")
    page.wait_for_selector("#step[data-step='0']")
    page.wait_for_selector("#agents select[data-agent='agent_3']")
    page.click("#play")
    page.wait_for_function("() => Number(document.getElementById('step').dataset.step) >= 10")
    page.click("#pause")
    with page.expect_download() as download:
        page.click("#gif")
    path = tmp_path / "episode.gif"
    download.value.save_as(path)
    with Image.open(path) as gif:
        assert gif.format == "GIF" and gif.n_frames >= 10
        gif.seek(gif.n_frames - 1)
        assert gif.convert("RGB").size[0] > 100
    assert "agent_0" in page.inner_text("#infos")


def test_watch_offers_each_agent_what_suits_it_and_goes_on_after_a_refusal(page):
    page.goto(page.studio_url + "#/watch?ref=blind_fetch")
    select = page.wait_for_selector("#agents select[data-agent='agent_0']")
    offered = select.eval_on_selector_all("option", "options => options.map(o => o.value)")
    assert "greedy" not in offered and "planner" in offered  # blind: no camera for greedy
    page.wait_for_selector("#step[data-step='0']")
    page.evaluate(  # a choice the page does not offer, as a stale page might send
        """() => {
            const select = document.querySelector("#agents select[data-agent='agent_0']");
            select.append(new Option("greedy", "greedy"));
            select.value = "greedy";
            select.dispatchEvent(new Event("change"));
        }"""
    )
    page.wait_for_selector("#agents select.refused[data-agent='agent_0']")
    assert "camera" in page.inner_text("#status")
    page.click("#step-once")  # the episode before the refusal still runs
    page.wait_for_selector("#step[data-step='1']")
    page.select_option("#agents select[data-agent='agent_0']", "random")
    page.wait_for_selector("#step[data-step='0']")
    page.wait_for_function("() => !document.querySelector('#agents select.refused')")


def test_a_dropped_episode_says_why_and_the_page_connects_again(page, monkeypatch):
    from flatland_ma.studio.episodes import Watch

    page.goto(page.studio_url + "#/watch?ref=fruits_poisons&seed=4")
    page.wait_for_selector("#step[data-step='0']")
    real, failures = Watch.advance, []

    def fails_once(self, keys=None):
        if not failures:
            failures.append(self)
            raise RuntimeError("a policy fell over")
        return real(self, keys)

    monkeypatch.setattr(Watch, "advance", fails_once)  # the server runs in this process
    page.click("#step-once")
    page.wait_for_function(
        "() => document.getElementById('status').textContent.includes('a policy fell over')"
    )
    page.wait_for_function(  # connected again: the same episode, from its start
        "() => document.getElementById('status').textContent === 'watch: fruits_poisons'"
    )
    page.wait_for_selector("#step[data-step='0']")
    page.click("#step-once")
    page.wait_for_selector("#step[data-step='1']")


def test_play_on_a_scenario_with_a_channel_chooses_words_by_key(page):
    page.goto(page.studio_url + "#/play?ref=signal_maps")
    page.wait_for_selector("#step[data-step='0']")
    assert "m: next word of say_0" in page.inner_text("#keys")
    page.click("#frame")
    page.keyboard.press("m")
    page.keyboard.down("ArrowUp")
    page.wait_for_function("() => Number(document.getElementById('step').dataset.step) >= 1")
    page.keyboard.up("ArrowUp")
    assert page.inner_text("#said") == "saying 1"


def test_screenshots_of_each_page(page):
    """The docs' pictures of the studio (docs/images/studio/), taken as the pages show."""
    SHOTS.mkdir(parents=True, exist_ok=True)
    page.goto(page.studio_url + "#/gallery")
    page.wait_for_function(
        "() => { const shown = [...document.querySelectorAll('#gallery img')].slice(0, 8); "
        "return shown.length === 8 && shown.every(i => i.complete && i.naturalWidth > 0); }"
    )
    page.screenshot(path=SHOTS / "gallery.png")
    open_editor(page, "0:my_room.yaml")
    replace_text(page, "n_agents: 1", "n_agents: 3\nn_agnets: 2")
    page.wait_for_selector(".problem")
    page.screenshot(path=SHOTS / "editor.png")
    page.goto(page.studio_url + "#/watch?ref=fruits_poisons_multi&seed=3")
    page.wait_for_selector("#step[data-step='0']")
    page.click("#play")
    page.wait_for_function("() => Number(document.getElementById('step').dataset.step) >= 30")
    page.click("#pause")
    page.screenshot(path=SHOTS / "watch.png")
    page.goto(page.studio_url + f"#/play?ref=fruits_poisons&seed={EATING_SEED}")
    page.wait_for_selector("#step[data-step='0']")
    page.click("#frame")
    page.keyboard.down("ArrowUp")
    page.wait_for_function("() => Number(document.getElementById('step').dataset.step) >= 12")
    page.keyboard.up("ArrowUp")
    page.screenshot(path=SHOTS / "play.png")
    for name in ("gallery", "editor", "watch", "play"):
        with Image.open(SHOTS / f"{name}.png") as shot:
            assert shot.size == (1280, 900)


def test_the_editor_completes_and_explains_keys_from_the_schema(page):
    open_editor(page, "fruits_poisons")
    page.evaluate(
        """() => {
            const view = window.studioEditor;
            const text = view.state.doc.toString();
            const at = text.indexOf("  max_steps: 500") + "  max_steps: 500".length;
            view.dispatch({changes: {from: at, insert: "\\n  sha"}, selection: {anchor: at + 6}});
            view.focus();
        }"""
    )
    page.keyboard.press("Control+Space")
    options = page.wait_for_selector(".cm-tooltip-autocomplete")
    assert "shared_end" in options.inner_text()  # a key of episode:, where the cursor is
    page.keyboard.press("Escape")
    page.hover(".cm-line:has-text('n_agents') >> text=n_agents")
    hover = page.wait_for_selector(".cm-tooltip-hover .hover")
    assert hover.inner_text().startswith("n_agents: integer")
