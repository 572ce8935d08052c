"""Faults in a user's own kinds are reported as theirs: a sensor whose readings do not fit
its space (in the single and the batched env, naming the sensor), a spec key its class
does not take, a part that needs a ``from_spec`` and has none, a generator that raises,
and a kind no installed package registers. The kinds live in a package outside the
repository (``test_extensions.PACKAGE`` plus one faulty module), run in a fresh process
since the registries are per process."""

import json
import re
import subprocess
import sys

import pytest

from tests.test_extensions import write_package

FAULTY = '''\
"""Kinds with the faults a user might write."""

from typing import Literal

import numpy as np
from gymnasium import spaces

from flatland_ma.agents.parts import Jointed
from flatland_ma.build.generators import Generator
from flatland_ma.scenario.spec_agent import PartBaseSpec
from flatland_ma.scenario.spec_sensors import SensorBaseSpec
from flatland_ma.scenario.spec_world import GeneratorBaseSpec
from flatland_ma.sensors.sensor import Sensor


class WideSpec(SensorBaseSpec):
    type: Literal["wide"]
    size: int = 5


class Wide(Sensor):
    """Declares three values and reads ``size``."""

    def __init__(self, name="wide", size=5):
        self.name, self.size = name, size
        self.space = spaces.Box(-1.0, 1.0, (3,), np.float32)

    def read(self, results, k):
        return np.zeros(self.size, np.float32)


class DialSpec(SensorBaseSpec):
    type: Literal["dial"]
    reach: float = 1.0


class Dial(Sensor):
    """Its spec has ``reach``; its constructor does not take it."""

    def __init__(self, name="dial"):
        self.name = name
        self.space = spaces.Box(-1.0, 1.0, (1,), np.float32)

    def read(self, results, k):
        return np.zeros(1, np.float32)


class TailSpec(PartBaseSpec):
    type: Literal["tail"]
    length: float = 5.0


class Tail(Jointed):
    """Needs the agent's radius, and has no ``from_spec`` to take it from the agent."""

    def __init__(self, base_radius, length=5.0):
        self.base_radius = base_radius

    def build(self, agent):
        raise AssertionError("never built: it cannot be made")

    def reach(self):
        return 1.0

    def top_speed(self, base_speed, base_turn):
        return base_speed

    def half_width(self):
        return 1.0


class BrokenSpec(GeneratorBaseSpec):
    generator: Literal["broken"]


class Broken(Generator):
    def generate(self, ground, rng):
        return 1 / 0


def register():
    import flatland_ma

    flatland_ma.register(WideSpec, Wide)
    flatland_ma.register(DialSpec, Dial)
    flatland_ma.register(TailSpec, Tail)
    flatland_ma.register(BrokenSpec, Broken)
'''

CHECK = r"""
import json, sys
from pathlib import Path

import flatland_ma
import my_world, my_world.faulty
from flatland_ma.kinds.registry import ExtensionError
from flatland_ma.scenario.errors import ScenarioError

home = Path(sys.argv[1])
my_world.register()
my_world.faulty.register()
found = {}


def attempt(label, make):
    try:
        make()
        found[label] = None
    except Exception as err:
        found[label] = [type(err).__name__, str(err)]


def scenario(text):
    path = home / f"case{len(found)}.yaml"
    path.write_text("extends: world.yaml\n" + text)
    return str(path)


wide = scenario("agent:\n  sensors:\n    - {type: camera, rays: 8}\n    - {type: wide}\n")
attempt("single", lambda: flatland_ma.parallel_env(wide).reset(seed=0))
attempt("batched", lambda: flatland_ma.BatchedParallelEnv(wide, num_worlds=2).reset(seed=0))
fits = scenario("agent:\n  sensors:\n    - {type: wide, size: 3}\n")
attempt("fits", lambda: flatland_ma.parallel_env(fits).reset(seed=0))
dial = scenario("agent:\n  sensors:\n    - {type: dial, reach: 2.0}\n")
attempt("dial", lambda: flatland_ma.check_scenario(dial))
tail = scenario("agent:\n  parts:\n    - {type: tail}\n")
attempt("tail", lambda: flatland_ma.parallel_env(tail))
broken = scenario("layout:\n  generators:\n    - {generator: broken}\n")
attempt("broken", lambda: flatland_ma.check_scenario(broken))
radar = scenario("agent:\n  sensors:\n    - {type: item_radar}\n")
attempt("radar", lambda: flatland_ma.load_scenario(radar))
import contextlib, io
from flatland_ma.cli import main

out = io.StringIO()
with contextlib.redirect_stdout(out):
    status = main(["validate", dial])
found["validate"] = [status, out.getvalue()]
print(json.dumps(found))
"""


@pytest.fixture(scope="module")
def found(tmp_path_factory):
    home = tmp_path_factory.mktemp("faults")
    write_package(home)
    (home / "my_world" / "faulty.py").write_text(FAULTY)
    env = {"PYTHONPATH": ":".join([str(home), *sys.path[1:]]), "PATH": "/usr/bin:/bin"}
    done = subprocess.run(
        [sys.executable, "-c", CHECK, str(home)],
        capture_output=True,
        text=True,
        env=env,
        timeout=900,  # a kill for a hung run only: it takes seconds
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("env", ["single", "batched"])
def test_a_reading_of_another_shape_than_its_space_names_the_sensor(found, env):
    kind, message = found[env]
    assert kind == "ExtensionError"
    assert "sensor 'wide'" in message and "my_world.faulty.Wide" in message
    assert "shape (5,)" in message and "(3,)" in message and "agent 0" in message


def test_a_reading_that_fits_its_space_passes(found):
    assert found["fits"] is None


def test_a_spec_key_the_class_does_not_take_is_the_classs_fault(found):
    kind, message = found["dial"]
    assert kind == "ExtensionError" and "please report" not in message
    assert "sensors[0]" in message and "my_world.faulty.Dial" in message
    assert "reach" in message and "accept every key of the spec" in message


def test_validate_reports_an_extensions_fault_without_a_traceback(found):
    status, output = found["validate"]
    assert status == 1
    assert "INVALID (an extension's code)" in output and "my_world.faulty.Dial" in output


def test_a_part_that_needs_from_spec_is_told_so(found):
    kind, message = found["tail"]
    assert kind == "ExtensionError" and "please report" not in message
    assert "parts[0]" in message and "the part 'tail' (my_world.faulty.Tail)" in message
    assert "base_radius" in message and "override the class's from_spec" in message


def test_an_exception_in_a_generator_names_its_code(found):
    kind, message = found["broken"]
    assert kind == "ExtensionError" and "please report" not in message
    assert "ZeroDivisionError" in message
    assert re.search(r"my_world\.faulty\.(Broken\.)?generate", message)  # qualname: 3.11+
    assert "faulty.py, line" in message


def test_an_unknown_kind_says_how_kinds_are_added(found):
    kind, message = found["radar"]
    assert kind == "ScenarioError" and "unknown sensor 'item_radar'" in message
    assert "entry point in the group 'flatland_ma.extensions'" in message
    assert "flatland_ma.register(spec, class)" in message


def test_a_from_spec_that_returns_no_instance_is_named_with_its_class():
    from flatland_ma.agents.parts import Part
    from flatland_ma.build.kind_faults import made_from_spec
    from flatland_ma.kinds.registry import ExtensionError
    from flatland_ma.sensors.sensor import Sensor

    class Lamp:  # from_spec returned something else than a Part or a Sensor
        pass

    lamp = Lamp()
    assert made_from_spec(lamp, Lamp, Lamp, "an agent's parts[0]") is lamp
    with pytest.raises(ExtensionError, match=r"parts\[0\]: .*Lamp.*returned None, not a Part"):
        made_from_spec(None, Part, Lamp, "an agent's parts[0]")
    with pytest.raises(ExtensionError, match=r"sensors\[2\]: .*Lamp.*, not a Sensor"):
        made_from_spec(lamp, Sensor, Lamp, "an agent's sensors[2]")
