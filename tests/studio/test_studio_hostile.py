"""The studio under hostile or heavy use: idle connections against the token holder, heavy
previews beside the pages' reads, stale requests, bad numbers, clients that leave, keys
sent outside play, episodes that fail, and paths kept to the server. Every wait is
bounded by a count (of polls, of messages), never by a clock."""

from __future__ import annotations

import asyncio
import json
import logging
import socket
import threading
import time
import urllib.error
import urllib.request

import pytest

pytest.importorskip("starlette", reason="the studio extra: pip install -e '.[studio]' in a clone")

from starlette.testclient import TestClient  # noqa: E402
from starlette.websockets import WebSocketDisconnect  # noqa: E402

from flatland_ma.play.keys import SCRIPT_KEYS  # noqa: E402
from flatland_ma.scenario.loader import scenario_path  # noqa: E402
from flatland_ma.studio import api as api_module  # noqa: E402
from flatland_ma.studio.app import create_app  # noqa: E402
from flatland_ma.studio.config import Limits, StudioConfig  # noqa: E402
from flatland_ma.studio.episodes import Watch  # noqa: E402
from flatland_ma.studio.serving import browser_hosts, server_options  # noqa: E402

HOST = "127.0.0.1:8765"
BASE = f"http://{HOST}"
FRUITS = scenario_path("fruits_poisons").read_text()
POLLS = 3000
"""Polls of a condition before a test gives up (each after a 10 ms sleep)."""


def client(config: StudioConfig, local: bool = True) -> TestClient:
    return TestClient(create_app(config, local=local), base_url=BASE)


def wait_until(condition, what: str) -> None:
    for _ in range(POLLS):
        if condition():
            return
        time.sleep(0.01)
    pytest.fail(f"never: {what}")


# -- idle connections and the token holder -----------------------------------------------


@pytest.fixture
def served(tmp_path):
    """A studio with a token, served by uvicorn on the loopback with the command's options
    (connections idle for 0.3 s closed), in a thread: (port, token, app)."""
    import uvicorn

    limits = Limits(idle_seconds=0.3, idle_episode_seconds=0.3, episodes=1)
    config = StudioConfig(token="tok-" + "x" * 24, limits=limits)
    app = create_app(config, local=False)
    listener = socket.socket()
    listener.bind(("127.0.0.1", 0))
    port = listener.getsockname()[1]
    server = uvicorn.Server(uvicorn.Config(app, **server_options(limits)))
    thread = threading.Thread(target=server.run, kwargs={"sockets": [listener]}, daemon=True)
    thread.start()
    wait_until(lambda: server.started, "the server started")
    yield port, config.token, app
    server.should_exit = True
    thread.join(timeout=30)
    listener.close()


def _get(port: int, path: str) -> int:
    try:
        with urllib.request.urlopen(f"http://127.0.0.1:{port}{path}", timeout=60) as answer:
            return answer.status
    except urllib.error.HTTPError as err:
        return err.code


def test_idle_connections_neither_lock_out_the_token_holder_nor_stay(served):
    port, token, _ = served
    idle = [socket.create_connection(("127.0.0.1", port)) for _ in range(80)]
    idle[0].sendall(b"GET /api/info HTTP/1.1\r\nHost: x\r\n")  # a head never finished
    try:
        answers = [_get(port, f"/api/info?token={token}") for _ in range(20)]
        assert answers == [200] * 20
        assert _get(port, "/api/info") == 403  # refused at once, never counted
        for connection in idle:  # each is closed by the server
            connection.settimeout(60)
            assert connection.recv(1) == b""
    finally:
        for connection in idle:
            connection.close()


def test_an_idle_episode_page_loses_its_slot_and_is_told_why(served):
    from websockets.sync.client import connect

    port, token, _ = served
    url = f"ws://127.0.0.1:{port}/api/episode?token={token}"
    with connect(url, open_timeout=60) as idle:
        idle.send(json.dumps({"type": "start", "scenario": "fruits_poisons"}))
        messages = [idle.recv(timeout=60) for _ in range(3)]  # ready, state, frame
        assert json.loads(messages[0])["type"] == "ready"
        while True:  # frames until the idle page is told, then closed
            message = idle.recv(timeout=60)
            if isinstance(message, str) and json.loads(message)["type"] == "error":
                break
        told = json.loads(message)
        assert told["fatal"] and told["code"] == 4000 and "said nothing" in told["message"]
    with connect(url, open_timeout=60) as next_page:  # the one slot is free again
        next_page.send(json.dumps({"type": "start", "scenario": "fruits_poisons"}))
        assert json.loads(next_page.recv(timeout=60))["type"] == "ready"


# -- heavy work beside the pages' reads ------------------------------------------------------


@pytest.fixture
def held_previews(monkeypatch):
    """Previews whose drawing waits for ``release`` (set it to let them finish)."""
    release = threading.Event()
    drawing = []
    real = api_module.layout_picture

    def slow(spec, seed):
        drawing.append(seed)
        assert release.wait(120), "the test never released the previews"
        return real(spec, seed)

    monkeypatch.setattr(api_module, "layout_picture", slow)
    yield release, drawing
    release.set()


def _post_in_thread(c: TestClient, path: str, body: dict, headers: dict, out: dict, key):
    def post():
        out[key] = c.post(path, json=body, headers=headers)

    thread = threading.Thread(target=post, daemon=True)
    thread.start()
    return thread


def test_the_pages_reads_are_answered_while_two_heavy_previews_run(held_previews):
    release, drawing = held_previews
    with client(StudioConfig()) as c:
        out: dict = {}
        threads = [
            _post_in_thread(
                c, "/api/preview", {"text": FRUITS, "seed": k}, {"x-studio-client": f"p{k}"}, out, k
            )
            for k in range(2)
        ]
        wait_until(lambda: len(drawing) == 2, "both previews drawing")
        assert c.get("/api/info").status_code == 200
        assert c.get("/api/gallery").status_code == 200
        assert c.get("/api/picture", params={"ref": "fruits_poisons"}).status_code == 200
        assert out == {}  # the previews are still held
        release.set()
        for thread in threads:
            thread.join(120)
        assert [out[k].status_code for k in range(2)] == [200, 200]


def test_a_pages_stale_request_is_superseded_by_its_newer_one(held_previews):
    release, drawing = held_previews
    with client(StudioConfig()) as c:
        api = c.app.state.api  # type: ignore[attr-defined]
        out: dict = {}
        mine = {"x-studio-client": "editor-1"}
        first = _post_in_thread(c, "/api/preview", {"text": FRUITS, "seed": 1}, mine, out, 1)
        wait_until(lambda: drawing == [1], "the first preview drawing")
        second = _post_in_thread(c, "/api/preview", {"text": FRUITS, "seed": 2}, mine, out, 2)
        wait_until(lambda: any(lane.waiting for lane in api.lanes._lanes.values()), "2 waits")
        third = _post_in_thread(c, "/api/preview", {"text": FRUITS, "seed": 3}, mine, out, 3)
        second.join(120)
        assert out[2].status_code == 409 and "superseded" in out[2].json()["error"]
        other = c.post("/api/validate", json={"text": FRUITS}, headers={"x-studio-client": "b"})
        assert other.status_code == 200  # another page's check does not wait for this one
        release.set()
        first.join(120)
        third.join(120)
        assert out[1].status_code == 200 and out[3].status_code == 200
        assert drawing == [1, 3]  # the stale one never ran
        assert len(api.lanes) <= api.lanes.clients


def test_a_job_whose_client_has_left_by_its_turn_does_not_run():
    from flatland_ma.studio.lanes import Lanes, Superseded

    ran = []

    async def left() -> bool:
        return False

    async def both():
        lanes = Lanes(threads=1, clients=4)
        with pytest.raises(Superseded):
            await lanes.run("page", ran.append, "gone", wanted=left)
        await lanes.run("page", ran.append, "here")
        return lanes

    lanes = asyncio.run(both())
    assert ran == ["here"] and lanes.superseded == 1 and lanes.ran == 1


def test_lanes_are_remembered_for_a_bounded_number_of_clients():
    with client(StudioConfig(limits=Limits(clients=4))) as c:
        for k in range(12):
            headers = {"x-studio-client": f"client-{k}"}
            assert (
                c.post("/api/validate", json={"text": FRUITS}, headers=headers).status_code == 200
            )
        assert len(c.app.state.api.lanes) == 4  # type: ignore[attr-defined]


# -- numbers, disconnects, keys ---------------------------------------------------------------


@pytest.mark.parametrize("seed", ["²", "٣", "1e3", "-1", "0x10", " 7", "99999999999", "", "1.5"])
def test_every_bad_number_gets_a_4xx_json_error(seed):
    with client(StudioConfig()) as c:
        picture = c.get("/api/picture", params={"ref": "fruits_poisons", "seed": seed})
        assert picture.status_code == 400 and "seed" in picture.json()["error"]
        preview = c.post("/api/preview", json={"text": FRUITS, "seed": seed})
        assert preview.status_code == 400 and "seed" in preview.json()["error"]


def test_bad_lengths_and_folder_numbers_get_4xx_json_errors():
    with client(StudioConfig()) as c:
        for length in ("²", "-5", "1e9"):
            answer = c.post(
                "/api/validate",
                content=b'{"text": ""}',
                headers={
                    "content-length": length.encode("latin-1"),
                    "content-type": "application/json",
                },
            )
            assert 400 <= answer.status_code < 500 and "error" in answer.json(), length
        answer = c.get("/api/scenario", params={"ref": "²:x.yaml"})
        assert answer.status_code == 400 and "N:FILE" in answer.json()["error"]


def test_a_client_that_leaves_mid_upload_is_no_error(caplog):
    app = create_app(StudioConfig())
    events = [
        {"type": "http.request", "body": b'{"text": "n_agents', "more_body": True},
        {"type": "http.disconnect"},
    ]
    sent = []

    async def receive():
        return events.pop(0) if events else {"type": "http.disconnect"}

    async def send(message):
        sent.append(message)

    scope = {
        "type": "http",
        "method": "POST",
        "path": "/api/validate",
        "raw_path": b"/api/validate",
        "query_string": b"",
        "headers": [(b"host", HOST.encode()), (b"content-length", b"400")],
        "client": ("127.0.0.1", 5000),
        "server": ("127.0.0.1", 8765),
        "scheme": "http",
        "root_path": "",
        "http_version": "1.1",
        "asgi": {"version": "3.0"},
    }
    with caplog.at_level(logging.DEBUG):
        asyncio.run(app(scope, receive, send))
    assert sent[0]["status"] == 400
    assert not [r for r in caplog.records if r.levelno >= logging.WARNING]


def test_keys_are_kept_only_while_playing_and_only_known_ones():
    with client(StudioConfig(limits=Limits(fps=60.0))) as c:
        hub = c.app.state.hub  # type: ignore[attr-defined]
        with c.websocket_connect("/api/episode", headers={"host": HOST}) as ws:
            ws.send_json({"type": "start", "scenario": "fruits_poisons"})
            assert ws.receive_json()["type"] == "ready"
            for k in range(2000):  # watching: keys mean nothing and are not kept
                ws.send_json({"type": "keys", "held": [f"k{k}"], "pressed": [f"p{k}", "up"]})
            ws.send_json({"type": "start", "mode": "play", "scenario": "fruits_poisons"})
            for _ in range(50):  # the watch's frames, then the play's ready
                message = ws.receive()
                if json.loads(message.get("text") or "{}").get("type") == "ready":
                    break
            (connection,) = hub.connections
            assert connection.pressed == set() and connection.held == set()
            for k in range(2000):  # playing: only the key table's names
                ws.send_json({"type": "keys", "held": [f"k{k}"], "pressed": [f"p{k}", "tab"]})
            ws.send_json({"type": "alive"})
            assert connection.pressed <= SCRIPT_KEYS and connection.held <= SCRIPT_KEYS


def test_an_episode_at_a_thousandth_of_a_frame_a_second_makes_a_gif():
    with client(StudioConfig()) as c:
        with c.websocket_connect("/api/episode", headers={"host": HOST}) as ws:
            ws.send_json({"type": "start", "scenario": "fruits_poisons", "fps": 0.001})
            ready = ws.receive_json()
            ws.receive_json()
            ws.receive_bytes()
            job = c.post(f"/api/episodes/{ready['episode']}/gif").json()
            wait_until(lambda: c.get(f"/api/gifs/{job['gif']}").json()["ready"], "the GIF")
            gif = c.get(f"/api/gifs/{job['gif']}/file")
            assert gif.status_code == 200 and gif.content[:3] == b"GIF"


# -- episodes that fail, paths, the command -----------------------------------------------


def test_an_episode_that_fails_tells_the_page_why_before_the_close(monkeypatch):
    def broken(self, keys=None):
        raise RuntimeError("a policy fell over")

    monkeypatch.setattr(Watch, "advance", broken)
    with client(StudioConfig()) as c:
        with pytest.raises(WebSocketDisconnect) as closed:
            with c.websocket_connect("/api/episode", headers={"host": HOST}) as ws:
                ws.send_json({"type": "start", "scenario": "fruits_poisons"})
                assert ws.receive_json()["type"] == "ready"
                ws.receive_json()
                ws.receive_bytes()
                ws.send_json({"type": "step"})
                told = ws.receive_json()
                assert told["fatal"] and told["code"] == 1011
                assert "RuntimeError: a policy fell over" in told["message"]
                ws.receive_json()
        assert closed.value.code == 1011 and "fell over" in closed.value.reason


def test_a_checkpoint_describing_a_huge_observation_is_refused_from_its_description(
    tmp_path, monkeypatch
):
    """0.6 MB of weights could describe a 16,384 x 16,384 observation; the loader probed
    the network with one such observation (1 GB) before comparing it with the agent's."""
    torch = pytest.importorskip("torch")
    pytest.importorskip("safetensors")
    from baselines.networks import Agent
    from flatland_ma.envs.parallel import FlatlandParallelEnv
    from flatland_ma.policies.checkpoint import write_checkpoint
    from tests.checkpoint_helpers import rewrite_description

    env = FlatlandParallelEnv("fruits_poisons")
    spaces = {"observation_space": env.observation_space("agent_0")}
    spaces["action_space"] = env.action_space("agent_0")
    runs = tmp_path / "runs"
    good = write_checkpoint(
        runs / "good.safetensors", Agent(**spaces, hidden=8), scenario="fruits_poisons", **spaces
    )
    huge = runs / "huge.safetensors"
    huge.write_bytes(good.read_bytes())
    rewrite_description(huge, lambda d: d["spaces"]["observation"].update(shape=[16384, 16384]))

    def no_tensor(*args, **kwargs):
        raise AssertionError("a tensor was made")

    monkeypatch.setattr(torch, "zeros", no_tensor)
    with client(StudioConfig(checkpoints=runs)) as c:
        offered = c.get("/api/policies", params={"ref": "fruits_poisons"}).json()["agents"]
        assert "checkpoint:good.safetensors" in offered[0]["policies"]
        assert "checkpoint:huge.safetensors" not in offered[0]["policies"]
        with c.websocket_connect("/api/episode", headers={"host": HOST}) as ws:
            policies = {"agent_0": "checkpoint:huge.safetensors"}
            ws.send_json({"type": "start", "scenario": "fruits_poisons", "policies": policies})
            refused = ws.receive_json()
            assert refused["agent"] == "agent_0"
            assert "an observation of 268,435,456 values" in refused["message"]
            monkeypatch.undo()  # a checkpoint that fits is probed with one observation
            policies = {"agent_0": "checkpoint:good.safetensors"}
            ws.send_json({"type": "start", "scenario": "fruits_poisons", "policies": policies})
            assert ws.receive_json()["type"] == "ready"


def test_messages_name_files_as_the_pages_do_not_by_server_paths(tmp_path):
    runs = tmp_path / "runs" / "ppo"
    runs.mkdir(parents=True)
    (runs / "junk.safetensors").write_bytes(b"\x80\x04 not a checkpoint")
    folder = tmp_path / "mine"
    folder.mkdir()
    config = StudioConfig(folders=(folder,), checkpoints=tmp_path / "runs")
    with client(config) as c:
        info = c.get("/api/info").json()
        assert str(tmp_path) not in json.dumps(info)
        with c.websocket_connect("/api/episode", headers={"host": HOST}) as ws:
            policies = {"agent_0": "checkpoint:ppo/junk.safetensors"}
            ws.send_json({"type": "start", "scenario": "fruits_poisons", "policies": policies})
            error = ws.receive_json()
        assert error["agent"] == "agent_0"
        assert "checkpoint:ppo/junk.safetensors" in error["message"]
        assert str(tmp_path) not in error["message"]


def test_the_command_prints_addresses_a_browser_opens_and_keeps_scores_in_a_folder(tmp_path):
    from flatland_ma.cli import build_parser
    from flatland_ma.cli.studio import config_of

    hosts = browser_hosts("0.0.0.0")
    assert "0.0.0.0" not in hosts and hosts[-1] == "127.0.0.1"
    assert browser_hosts("10.1.2.3") == ["10.1.2.3"]
    given = build_parser().parse_args(["studio", "--scenarios", str(tmp_path)])
    assert config_of(given).scores == tmp_path / "play_scores.csv"
    assert config_of(build_parser().parse_args(["studio"])).scores is None
