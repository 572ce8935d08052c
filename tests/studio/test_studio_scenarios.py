"""Every shipped scenario watches and plays in the studio (through its API and WebSocket,
in process): each agent is offered the policies that can drive it, with a default among
them, chosen before the episode starts; watch steps with the defaults, play steps on the
up key; a refused policy names its agent and leaves the episode running."""

from __future__ import annotations

import json

import pytest

pytest.importorskip("starlette", reason="the studio extra: pip install -e '.[studio]' in a clone")

from starlette.testclient import TestClient  # noqa: E402

from flatland_ma.scenario.loader import list_scenarios  # noqa: E402
from flatland_ma.studio.app import create_app  # noqa: E402
from flatland_ma.studio.config import Limits, StudioConfig  # noqa: E402

HOST = "127.0.0.1:8765"
MESSAGES = 20
"""Messages read past before a test gives up on the one it waits for."""


@pytest.fixture(scope="module")
def studio():
    app = create_app(StudioConfig(limits=Limits(fps=60.0)))
    with TestClient(app, base_url=f"http://{HOST}") as c:
        yield c


def _next(ws, kind: str) -> dict:
    for _ in range(MESSAGES):
        message = ws.receive()
        text = message.get("text")
        if text is None:
            continue
        value = json.loads(text)
        assert value["type"] in (kind, "state"), value
        if value["type"] == kind:
            return value
    pytest.fail(f"no {kind} message")


@pytest.mark.parametrize("scenario", list_scenarios())
def test_every_shipped_scenario_watches_and_plays_with_its_offered_policies(studio, scenario):
    offered = studio.get("/api/policies", params={"ref": scenario})
    assert offered.status_code == 200, offered.text
    agents = offered.json()["agents"]
    for entry in agents:
        assert entry["default"] in entry["policies"] and "random" in entry["policies"]
    with studio.websocket_connect("/api/episode", headers={"host": HOST}) as ws:
        chosen = {entry["agent"]: entry["default"] for entry in agents}
        ws.send_json({"type": "start", "scenario": scenario, "policies": chosen})
        ready = _next(ws, "ready")
        assert ready["agents"] == [entry["agent"] for entry in agents]
        assert _next(ws, "state")["step"] == 0
        ws.send_json({"type": "step"})
        assert _next(ws, "state")["step"] == 1
        ws.send_json({"type": "start", "mode": "play", "scenario": scenario})
        ready = _next(ws, "ready")
        assert all(any(k.startswith("up:") for k in keys) for keys in ready["keys"].values())
        assert _next(ws, "state")["step"] == 0
        ws.send_json({"type": "keys", "held": ["up"], "pressed": ["up"]})
        assert _next(ws, "state")["step"] == 1
        ws.send_json({"type": "keys", "held": [], "pressed": []})


@pytest.mark.parametrize("scenario", ["blind_fetch", "scent_rooms", "signal_maps", "signal_rooms"])
def test_a_policy_that_cannot_drive_an_agent_is_refused_and_the_episode_goes_on(studio, scenario):
    agents = studio.get("/api/policies", params={"ref": scenario}).json()["agents"]
    blind = next(e["agent"] for e in agents if "greedy" not in e["policies"])
    with studio.websocket_connect("/api/episode", headers={"host": HOST}) as ws:
        ws.send_json({"type": "start", "scenario": scenario})  # every agent its default
        _next(ws, "ready")
        _next(ws, "state")
        ws.send_json({"type": "start", "scenario": scenario, "policies": {blind: "greedy"}})
        refused = _next(ws, "error")
        assert refused["agent"] == blind and "camera" in refused["message"]
        ws.send_json({"type": "step"})  # the episode before still runs
        assert _next(ws, "state")["step"] == 1
        ws.send_json({"type": "start", "scenario": scenario, "policies": {blind: "random"}})
        assert _next(ws, "ready")["type"] == "ready"  # another choice, a new episode
