"""The studio's API through an HTTP client (Starlette's TestClient): the gallery, the
editor's endpoints, watch and play over the WebSocket, saving, and every refusal."""

from __future__ import annotations

import csv
import io
import os
import time

import pytest

pytest.importorskip("starlette", reason="the studio extra: pip install -e '.[studio]' in a clone")

from PIL import Image  # noqa: E402
from starlette.testclient import TestClient  # noqa: E402
from starlette.websockets import WebSocketDisconnect  # noqa: E402

from flatland_ma.scenario.loader import list_scenarios, scenario_path  # noqa: E402
from flatland_ma.studio.app import create_app  # noqa: E402
from flatland_ma.studio.config import Limits, StudioConfig  # noqa: E402

HOST = "127.0.0.1:8765"
BASE = f"http://{HOST}"
FRUITS = scenario_path("fruits_poisons").read_text()
SHORT = FRUITS.replace("max_steps: 500", "max_steps: 4")


def client(config: StudioConfig, local: bool = True) -> TestClient:
    return TestClient(create_app(config, local=local), base_url=BASE)


def socket(c: TestClient, **headers):
    return c.websocket_connect("/api/episode", headers={"host": HOST, **headers})


@pytest.fixture
def folders(tmp_path):
    mine, other = tmp_path / "mine", tmp_path / "other"
    mine.mkdir()
    other.mkdir()
    (mine / "short.yaml").write_text(SHORT)
    (mine / "broken.yaml").write_text("n_agents: [1\n")
    (other / "secret.yaml").write_text(FRUITS)
    return mine, other


@pytest.fixture
def studio(folders, tmp_path):
    scores = tmp_path / "scores.csv"
    config = StudioConfig(folders=(folders[0],), scores=scores, limits=Limits(fps=60.0))
    with client(config) as c:
        yield c


def png(data: bytes) -> Image.Image:
    image = Image.open(io.BytesIO(data))
    image.load()
    return image


def receive_state(ws) -> tuple[dict, bytes]:
    """The next state message and the frame after it (errors fail the test)."""
    message = ws.receive_json()
    assert message["type"] == "state", message
    return message, ws.receive_bytes()


# -- gallery and pictures ---------------------------------------------------------------


def test_gallery_lists_every_shipped_scenario_and_the_folder_files(studio):
    cards = {c["ref"]: c for c in studio.get("/api/gallery").json()}
    assert set(list_scenarios()) <= set(cards)
    assert cards["fruits_poisons"]["gym_id"] == "flatland_ma/FruitsPoisons-v0"
    assert cards["fruits_poisons"]["description"].startswith("The paper's task")
    assert cards["fruits_poisons_multi"]["gym_id"] is None  # four agents: no Gymnasium id
    assert cards["0:short.yaml"]["n_agents"] == 1
    (problem,) = cards["0:broken.yaml"]["problems"]
    assert problem["line"] == 2 and "not valid YAML" in problem["message"]
    assert not any("secret" in ref for ref in cards)


def test_pictures_are_pngs_of_the_layout(studio):
    first = studio.get("/api/picture", params={"ref": "fruits_poisons", "seed": 1})
    assert first.status_code == 200 and first.headers["content-type"] == "image/png"
    assert png(first.content).size[0] > 100
    again = studio.get("/api/picture", params={"ref": "fruits_poisons", "seed": 2})
    assert again.content != first.content  # the items lie elsewhere at another seed
    assert studio.get("/api/picture", params={"ref": "0:short.yaml"}).status_code == 200


def test_scenario_text_and_schema(studio):
    assert studio.get("/api/scenario", params={"ref": "0:short.yaml"}).json()["text"] == SHORT
    schema = studio.get("/api/schema").json()
    assert "n_agents" in schema["properties"]


# -- validate, preview, save --------------------------------------------------------------


def test_validate_locates_each_fault_at_its_line(studio):
    assert studio.post("/api/validate", json={"text": FRUITS}).json()["ok"] is True
    lines = FRUITS.splitlines()
    at = next(i for i, line in enumerate(lines) if line.startswith("n_agents"))
    lines.insert(at + 1, "n_agnets: 2")
    answer = studio.post("/api/validate", json={"text": "\n".join(lines)}).json()
    assert answer["ok"] is False
    (problem,) = answer["problems"]
    assert problem["line"] == at + 2 and problem["path"] == "n_agnets"
    assert "unknown key" in problem["message"]
    broken = studio.post("/api/validate", json={"text": "arena: {size: [300, 300]\n"}).json()
    assert broken["ok"] is False and broken["problems"][0]["line"] is not None


def test_extends_reaches_shipped_scenarios_and_the_same_folder_only(studio, folders):
    ok = studio.post("/api/validate", json={"text": "extends: fruits_poisons\nn_agents: 2\n"})
    assert ok.json() == {"ok": True, "problems": [], "n_agents": 2}
    beside = {"text": "extends: short.yaml\n", "folder": 0}
    assert studio.post("/api/validate", json=beside).json()["ok"] is True
    for target in ("/etc/passwd", "../other/secret.yaml", str(folders[1] / "secret.yaml")):
        answer = studio.post("/api/validate", json={"text": f"extends: {target}\n", "folder": 0})
        assert answer.json()["ok"] is False, target
        assert answer.json()["problems"][0]["path"] == "extends"


def test_preview_follows_the_number_of_agents(studio):
    one = studio.post("/api/preview", json={"text": FRUITS, "seed": 3})
    three = studio.post("/api/preview", json={"text": FRUITS + "\n" * 0, "seed": 3})
    assert one.content == three.content
    more = studio.post(
        "/api/preview", json={"text": FRUITS.replace("n_agents: 1", "n_agents: 3"), "seed": 3}
    )
    assert more.status_code == 200 and more.content != one.content
    bad = studio.post("/api/preview", json={"text": FRUITS.replace("n_agents: 1", "n_agents: -1")})
    assert bad.status_code == 422 and bad.json()["problems"][0]["path"] == "n_agents"
    assert studio.post("/api/preview", json={"text": FRUITS, "seed": -1}).status_code == 400


def test_save_writes_into_a_given_folder_only(studio, folders):
    made = studio.post("/api/save", json={"text": SHORT, "folder": 0, "name": "new.yaml"})
    assert made.status_code == 201 and made.json() == {"ref": "0:new.yaml"}
    assert (folders[0] / "new.yaml").read_text() == SHORT
    again = studio.post("/api/save", json={"text": FRUITS, "folder": 0, "name": "new.yaml"})
    assert again.status_code == 409
    replace = {"text": FRUITS, "folder": 0, "name": "new.yaml", "overwrite": True}
    assert studio.post("/api/save", json=replace).status_code == 201
    assert (folders[0] / "new.yaml").read_text() == FRUITS
    for name in ("../other/x.yaml", "/tmp/x.yaml", "sub/x.yaml", ".hidden.yaml", "x.py", "", 7):
        answer = studio.post("/api/save", json={"text": SHORT, "folder": 0, "name": name})
        assert answer.status_code == 400, name
    assert (
        studio.post("/api/save", json={"text": SHORT, "folder": 1, "name": "a.yaml"}).status_code
        == 400
    )
    assert sorted(p.name for p in folders[1].iterdir()) == ["secret.yaml"]


def test_symbolic_links_out_of_a_folder_are_refused(studio, folders):
    mine, other = folders
    os.symlink(other / "secret.yaml", mine / "link.yaml")
    os.symlink(other, mine / "away")
    cards = {c["ref"] for c in studio.get("/api/gallery").json()}
    assert "0:link.yaml" not in cards
    assert studio.get("/api/scenario", params={"ref": "0:link.yaml"}).status_code == 400
    save = {"text": SHORT, "folder": 0, "name": "link.yaml", "overwrite": True}
    assert studio.post("/api/save", json=save).status_code == 400
    assert (other / "secret.yaml").read_text() == FRUITS


def test_oversize_and_malformed_requests_are_refused(folders):
    config = StudioConfig(folders=(folders[0],), limits=Limits(request_bytes=2048))
    with client(config) as c:
        big = c.post("/api/validate", json={"text": "#" * 4096})
        assert big.status_code == 413
        assert (
            c.post("/api/validate", content=b"{nope", headers={"content-type": "x"}).status_code
            == 400
        )
        assert c.post("/api/validate", json=[1, 2]).status_code == 400
        assert c.post("/api/validate", json={"text": 5}).status_code == 400
        assert c.get("/api/scenario", params={"ref": "9:x.yaml"}).status_code == 400
        assert c.get("/api/scenario", params={"ref": "no_such_world"}).status_code == 400
        assert (
            c.get("/api/picture", params={"ref": "fruits_poisons", "seed": "x"}).status_code == 400
        )
        assert c.get("/api/gallery").status_code == 200  # still serving


# -- the guards -----------------------------------------------------------------------------


def test_a_studio_beyond_the_loopback_needs_its_token(folders):
    config = StudioConfig(folders=(folders[0],), token="s3cret-token")
    with client(config, local=False) as c:
        assert c.get("/api/info").status_code == 403
        assert c.get("/api/info", params={"token": "wrong"}).status_code == 403
        assert c.get("/api/info", params={"token": "s3cret-token"}).status_code == 200
        assert c.get("/api/info", headers={"x-studio-token": "s3cret-token"}).status_code == 200
        c.cookies.set("flatland_studio_token", "s3cret-token")
        assert c.get("/api/info").status_code == 200
        c.cookies.clear()
        with pytest.raises(WebSocketDisconnect) as closed:
            with socket(c) as ws:
                ws.receive_json()
        assert closed.value.code == 1008
        with c.websocket_connect("/api/episode?token=s3cret-token") as ws:
            ws.send_json({"type": "pause"})
            assert ws.receive_json()["type"] == "error"


def test_on_the_loopback_other_hosts_and_origins_are_refused(studio):
    assert studio.get("/api/info", headers={"host": "evil.example:8765"}).status_code == 403
    hostile = {"origin": "http://evil.example"}
    assert studio.post("/api/validate", json={"text": FRUITS}, headers=hostile).status_code == 403
    same = {"origin": BASE}
    assert studio.post("/api/validate", json={"text": FRUITS}, headers=same).status_code == 200
    with pytest.raises(WebSocketDisconnect) as closed:
        with socket(studio, **hostile) as ws:
            ws.receive_json()
    assert closed.value.code == 1008


# -- watch and play -------------------------------------------------------------------------


def test_watch_steps_plays_pauses_and_downloads_a_gif(studio):
    with socket(studio) as ws:
        ws.send_json({"type": "start", "scenario": "fruits_poisons_multi", "seed": 2, "fps": 60,
                      "policies": {"agent_1": "random", "agent_2": "idle"}})  # fmt: skip
        ready = ws.receive_json()
        assert ready["type"] == "ready" and len(ready["agents"]) == 4
        state, frame = receive_state(ws)
        assert state["step"] == 0 and png(frame).format == "JPEG"
        ws.send_json({"type": "step"})
        state, _ = receive_state(ws)
        assert state["step"] == 1 and set(state["infos"]["agent_0"]) >= {"score", "fruits"}
        ws.send_json({"type": "play"})
        for _ in range(5):
            state, _ = receive_state(ws)
        assert state["step"] == 6
        ws.send_json({"type": "pause"})
        ws.send_json({"type": "reset", "seed": 2})  # a new recording from here
        for _ in range(20):  # frames the play sent before the pause came, then ready
            message = ws.receive()
            if "text" in message and '"ready"' in message["text"]:
                break
        receive_state(ws)
        for fps in (60, 60, 4):  # the viewer slows down: 250 ms a frame
            ws.send_json({"type": "speed", "fps": fps})
            ws.send_json({"type": "step"})
            state, _ = receive_state(ws)
        image = gif_of(studio, ready["episode"])
        assert image.format == "GIF" and image.n_frames == 4 and image.width <= 480
        durations = []
        for index in range(image.n_frames):
            image.seek(index)
            durations.append(image.info["duration"])
        assert durations == [20, 20, 20, 250]  # as long as the viewer saw each
    assert studio.post(f"/api/episodes/{ready['episode']}/gif").status_code == 404  # closed


def gif_of(c: TestClient, episode: str, polls: int = 2000) -> Image.Image:
    """The GIF of an episode, made in the background: its progress polled (at most
    ``polls`` times) until it is ready, then downloaded."""
    started = c.post(f"/api/episodes/{episode}/gif")
    assert started.status_code == 202, started.text
    job = started.json()
    assert job["total"] >= 1 and job["done"] <= job["total"]
    for _ in range(polls):
        progress = c.get(f"/api/gifs/{job['gif']}").json()
        assert progress["error"] is None
        if progress["ready"]:
            break
        time.sleep(0.01)
    assert progress["ready"] and progress["done"] == progress["total"]
    download = c.get(f"/api/gifs/{job['gif']}/file")
    assert download.headers["content-type"] == "image/gif"
    assert len(download.content) == progress["bytes"]
    return png(download.content)


def test_bad_messages_scenarios_and_policies_get_errors_and_the_socket_stays(studio):
    with socket(studio) as ws:
        for message in (
            {"type": "dance"},
            {"type": "start", "scenario": "fruits_poisons", "seed": -4},
            {"type": "start", "scenario": "fruits_poisons", "extra": 1},
            {"type": "start", "scenario": "../../etc/passwd"},
            {"type": "start", "scenario": "fruits_poisons", "policies": {"agent_0": "os.system"}},
            {"type": "start", "scenario": "fruits_poisons",
             "policies": {"agent_0": "checkpoint:x.safetensors"}},
            {"type": "start", "scenario": "fruits_poisons", "policies": {"agent_9": "random"}},
            {"type": "step"},
        ):  # fmt: skip
            ws.send_json(message)
            assert ws.receive_json()["type"] == "error", message
        ws.send_text("not json")
        assert ws.receive_json()["type"] == "error"
        ws.send_bytes(b"\x00\x01")
        assert ws.receive_json()["type"] == "error"
        ws.send_text('{"type": "keys", "held": ["' + "a" * 5000 + '"]}')
        assert "bytes" in ws.receive_json()["message"]
        ws.send_json({"type": "start", "text": "n_agents: 1\nwat: 2\n"})
        error = ws.receive_json()
        assert error["problems"][0]["line"] == 2 and error["problems"][0]["path"] == "wat"
        ws.send_json({"type": "start", "scenario": "0:short.yaml"})
        assert ws.receive_json()["type"] == "ready"


def test_play_moves_on_held_keys_only_and_writes_a_row_per_episode(studio, tmp_path):
    with socket(studio) as ws:
        ws.send_json({"type": "start", "mode": "play", "scenario": "0:short.yaml", "seed": 5,
                      "fps": 60})  # fmt: skip
        ready = ws.receive_json()
        assert "up: forward" in ready["keys"]["agent_0"]
        state, _ = receive_state(ws)
        assert state["step"] == 0 and state["agent"] == "agent_0"
        ws.send_json({"type": "keys", "held": ["up"], "pressed": ["up"]})
        steps = [receive_state(ws)[0] for _ in range(4)]
        assert [s["step"] for s in steps[:3]] == [1, 2, 3]
        assert steps[3]["episode"] == 2  # the 4-step episode ended and the next began
        ws.send_json({"type": "keys", "held": [], "pressed": []})
    with (tmp_path / "scores.csv").open() as handle:
        rows = list(csv.DictReader(handle))
    assert len(rows) == 1
    assert rows[0]["scenario"] == "0:short.yaml" and rows[0]["seed"] == "5"
    assert rows[0]["agent"] == "agent_0" and rows[0]["steps"] == "4"


def test_play_tab_hands_the_keys_to_the_next_agent(studio):
    with socket(studio) as ws:
        ws.send_json({"type": "start", "mode": "play", "scenario": "fruits_poisons_multi",
                      "others": "idle", "fps": 60})  # fmt: skip
        ws.receive_json()
        assert receive_state(ws)[0]["agent"] == "agent_0"
        ws.send_json({"type": "keys", "held": [], "pressed": ["tab"]})
        assert receive_state(ws)[0]["agent"] == "agent_1"


def test_episodes_at_once_are_bounded(folders):
    config = StudioConfig(folders=(folders[0],), limits=Limits(episodes=1))
    with client(config) as c, socket(c) as first:
        first.send_json({"type": "start", "scenario": "fruits_poisons"})
        assert first.receive_json()["type"] == "ready"
        with pytest.raises(WebSocketDisconnect) as closed:
            with socket(c) as second:  # connected, it holds no slot until it starts one
                second.send_json({"type": "start", "scenario": "fruits_poisons"})
                busy = second.receive_json()
                assert "busy" in busy["message"] and busy["fatal"] and busy["code"] == 1013
                second.receive_json()
        assert closed.value.code == 1013 and "busy" in closed.value.reason


def test_checkpoints_come_from_their_folder_through_the_data_only_loader(folders, tmp_path):
    runs = tmp_path / "runs" / "ppo"
    runs.mkdir(parents=True)
    (runs / "junk.safetensors").write_bytes(b"\x80\x04 not a checkpoint")
    (folders[1] / "away.safetensors").write_bytes(b"")
    config = StudioConfig(checkpoints=tmp_path / "runs")
    with client(config) as c, socket(c) as ws:
        assert "checkpoint:ppo/junk.safetensors" in c.get("/api/info").json()["policies"]
        errors = {}
        for name in ("ppo/junk.safetensors", "../other/away.safetensors", "/etc/x.safetensors"):
            policies = {"agent_0": f"checkpoint:{name}"}
            ws.send_json({"type": "start", "scenario": "fruits_poisons", "policies": policies})
            errors[name] = ws.receive_json()
        assert all(e["type"] == "error" for e in errors.values())
        assert "junk.safetensors" in errors["ppo/junk.safetensors"]["message"]
        assert "'..'" in errors["../other/away.safetensors"]["message"]
        assert "absolute" in errors["/etc/x.safetensors"]["message"]
        ws.send_json({"type": "start", "scenario": "fruits_poisons"})
        assert ws.receive_json()["type"] == "ready"


def test_the_command_checks_its_options_and_asks_a_token_beyond_the_loopback(tmp_path):
    from flatland_ma.cli import build_parser, main
    from flatland_ma.cli.studio import config_of

    assert main(["studio", "--host", "bad host"]) == 2
    assert main(["studio", "--port", "70000"]) == 2
    assert main(["studio", "--scenarios", str(tmp_path / "missing")]) == 2
    local = build_parser().parse_args(["studio", "--scenarios", str(tmp_path)])
    assert config_of(local).token is None and config_of(local).folders == (tmp_path,)
    wide = build_parser().parse_args(["studio", "--host", "0.0.0.0"])
    assert len(config_of(wide).token or "") >= 24
