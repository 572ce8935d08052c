"""The study of many worlds in one pymunk space (``benchmarks/tiled_spaces.py``), on a
tiny configuration bounded by steps: its separate copies are the env's physics, its tiled
space keeps worlds apart and matches separate spaces moved by the same offsets, and a run
writes every figure the performance page quotes."""

from __future__ import annotations

import json

import numpy as np
import pytest

from benchmarks import tiled_spaces as tiles


def test_a_separate_copy_replays_the_worlds_own_step():
    assert tiles.faithful("fruits_poisons_multi", steps=30)
    assert tiles.faithful("fruits_poisons", steps=30)


def test_tiles_lie_apart_and_hold_every_world():
    sources = tiles.templates("fruits_poisons_multi", 5, seed=0)
    tiled = tiles.Arrangement(sources, "tiled")
    assert len(tiled.spaces) == 1
    space = tiled.spaces[0]
    assert len(space.bodies) == sum(len(t.bodies) for t in sources)
    # Every world's shapes lie within its own tile, and no two tiles' boxes meet.
    boxes = []
    for k, source in enumerate(sources):
        dx, dy = tiled.offsets[k]
        width, height = source.size
        boxes.append((dx, dy, dx + width, dy + height))
    for k, (x0, y0, x1, y1) in enumerate(boxes):
        for j, (u0, v0, u1, v1) in enumerate(boxes):
            if j != k:
                assert x1 < u0 or u1 < x0 or y1 < v0 or v1 < y0
    # Every shape (its bounding box; the walls stand up to 10 units outside the arena)
    # lies in the tile of its own world, and none reaches another's.
    margin = 10.0
    assert len(tiled.world_of) == len(space.shapes)
    for shape in space.shapes:
        x0, y0, x1, y1 = boxes[tiled.world_of[shape]]
        bb = shape.cache_bb()
        assert x0 - margin <= bb.left and bb.right <= x1 + margin
        assert y0 - margin <= bb.bottom and bb.top <= y1 + margin
    for agents, (x0, y0, x1, y1) in zip(tiled.agents, boxes):
        for body in agents:
            x, y = body.position
            assert x0 < x < x1 and y0 < y < y1


def test_tiled_worlds_move_as_separate_spaces_moved_by_their_offsets():
    sources = tiles.templates("fruits_poisons_multi", 4, seed=1)
    out = tiles.study(sources, steps=40, seed=1)
    same = out["tiled vs separate_shifted"]
    assert same["worlds_bit_identical"] == 4
    assert same["worlds_same_contacts_as_sets"] == 4
    # World 0's tile is at the origin: it alone is the separate space's to the bit.
    moved = out["tiled vs separate"]
    assert moved["worlds_bit_identical"] >= 1
    assert moved["max_position_difference_at"]["10"] < 1e-6
    assert out["contacts_per_world_step"] > 0
    # Stacked at the origin, kept apart by filters: no offset, so no rounding of its own.
    stacked = out["stacked vs separate"]
    assert stacked["worlds_bit_identical"] == 4
    assert stacked["worlds_same_contacts_as_sets"] == 4


def test_a_stack_holds_no_more_worlds_than_its_filter_bits():
    sources = tiles.templates("fruits_poisons", 1, seed=0) * (tiles.STACKED_MAX + 1)
    with pytest.raises(ValueError, match="'stacked' of 28 worlds"):
        tiles.Arrangement(sources, "stacked")
    assert "stacked" not in tiles.timed_arrangements(tiles.STACKED_MAX + 1)


def test_the_readers_agree_and_a_run_writes_its_figures(tmp_path, capsys):
    path = tmp_path / "tiled.json"
    tiles.main(
        [
            "--scenarios",
            "fruits_poisons",
            "--worlds",
            "3",
            "--steps",
            "2",
            "--rounds",
            "2",
            "--study-steps",
            "12",
            "--json",
            str(path),
        ]
    )
    result = json.loads(path.read_text())
    (row,) = result["rows"]
    assert row["worlds"] == 3 and row["agents"] == 1
    assert set(row["physics"]) == {
        "separate",
        "tiled",
        "tiled_hash",
        "tiled_groups",
        "stacked",
        "empty_spaces",
    }
    assert all(len(v) == 2 and min(v) > 0 for v in row["physics"].values())
    assert {"tiled_batch", "separate_batch", "separate_attributes"} <= set(row["poses"])
    assert result["faithful"] == {"fruits_poisons": True}
    assert "tiled vs separate_shifted" in row["trajectories"]
    assert "physics separate" in capsys.readouterr().out


def test_the_tiled_reader_reads_world_coordinates(monkeypatch):
    monkeypatch.setattr(tiles, "GROUP", 2)  # spaces of two worlds, the last of one
    sources = tiles.templates("fruits_poisons_multi", 3, seed=2)
    separate = tiles.Arrangement(sources, "separate")
    for kind in ("tiled", "tiled_groups"):
        tiled = tiles.Arrangement(sources, kind)
        assert len(tiled.spaces) == (1 if kind == "tiled" else 2)
        reader = tiles.TiledReader(tiled)
        reader.read()
        assert np.allclose(reader.pose, separate.poses(), rtol=0, atol=1e-9)
