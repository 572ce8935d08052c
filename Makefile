# Every target sets up .venv from nothing if needed, then runs.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
# The CPU build of torch; installed before the project so that its torch>=2.2 is already met.
TORCH := torch==2.13.0

.PHONY: demo test test-slow test-newest-pymunk test-rllib test-clients soak bench bench-learn performance-page docs docs-site docs-check studio-assets studio-check reference lint clean reproduce reproduce-multi results benchmark benchmark-table

# Two steps: the core (what `make demo` needs: the package and its own dependencies,
# about 360 MB), then torch and every extra the tests use (about 2.4 GB in all).
CORE_STAMP := $(VENV)/.core-installed

$(CORE_STAMP): pyproject.toml
	@echo "==> [setup 1/2] creating $(VENV) ($(PYTHON) -m venv) and updating pip"
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	@echo "==> [setup 2/2] installing flatland_ma and only what it needs to run (numpy, numba,"
	@echo "    pymunk, gymnasium, pettingzoo, pydantic, pillow, pyyaml: about 360 MB, a minute here)"
	$(BIN)/python -m pip install --disable-pip-version-check -e .
	touch $(CORE_STAMP)

$(STAMP): $(CORE_STAMP)
	@echo "==> [tests 1/2] installing $(TORCH) (the CPU build where the index has it)"
	$(BIN)/python -m pip install --disable-pip-version-check "$(TORCH)" || \
		$(BIN)/python -m pip install --disable-pip-version-check "$(TORCH)" --index-url https://download.pytorch.org/whl/cpu
	@echo "==> [tests 2/2] installing the extras the tests use: dev, train, render, clients, studio"
	$(BIN)/python -m pip install --disable-pip-version-check -e ".[dev,train,render,clients,studio]"
	touch $(STAMP)

demo: $(CORE_STAMP)
	@echo "==> playing fruits_poisons: 10 episodes each of a scripted and a random agent (the"
	@echo "    first run compiles the ray kernel; about 20 s in all here)"
	$(BIN)/flatland-ma demo

# The default suite, spread over every core (pytest-xdist); `make test-slow` runs the long ones.
test: $(STAMP)
	$(BIN)/python -m pytest -n auto --dist worksteal

test-slow: $(STAMP)
	$(BIN)/python -m pytest -n auto -m slow

# The bridge to pymunk's internals (flatland_ma/world/physics.py) against the newest pymunk
# release, beyond the pin of pyproject.toml, in an environment of its own: the tests marked
# pymunk_bridge (the tiers, the structs read by offset, the recorded trajectories).
NEWEST_PYMUNK := .venv-pymunk-newest
test-newest-pymunk:
	rm -rf $(NEWEST_PYMUNK)
	$(PYTHON) -m venv $(NEWEST_PYMUNK)
	$(NEWEST_PYMUNK)/bin/python -m pip install --quiet -e . pytest pytest-xdist hypothesis
	$(NEWEST_PYMUNK)/bin/python -m pip install --quiet --upgrade --no-deps pymunk
	$(NEWEST_PYMUNK)/bin/python -c "import pymunk; print('pymunk', pymunk.version)"
	$(NEWEST_PYMUNK)/bin/python -m pytest -q -p no:cacheprovider -m pymunk_bridge \
		tests/world/test_physics_bridge.py tests/test_trajectories.py

# Ray RLlib in an environment of its own (ray pins gymnasium 1.2.2): baselines/rllib_ppo.py
# for one iteration on a local Ray instance, and Gymnasium ids in a fresh process.
RLLIB := .venv-rllib
$(RLLIB)/.installed: pyproject.toml baselines/requirements-rllib.txt
	$(PYTHON) -m venv $(RLLIB)
	$(RLLIB)/bin/python -m pip install --quiet --upgrade pip
	$(RLLIB)/bin/python -m pip install --quiet "$(TORCH)" || \
		$(RLLIB)/bin/python -m pip install --quiet "$(TORCH)" --index-url https://download.pytorch.org/whl/cpu
	$(RLLIB)/bin/python -m pip install --quiet -r baselines/requirements-rllib.txt
	$(RLLIB)/bin/python -m pip install --quiet -e .
	touch $(RLLIB)/.installed

test-rllib: $(RLLIB)/.installed
	$(RLLIB)/bin/python -m pytest -q -p no:cacheprovider tests/rllib

# Every recipe of docs/integrations.md on every scenario type it lists (tests/clients/):
# the clients extra's in .venv, AgileRL and BenchMARL each in an environment of its own
# (.venv-clients-NAME from tests/clients/requirements-NAME.txt: their pins clash with ours),
# RLlib in make test-rllib's.
CLIENT_VENVS := agilerl benchmarl
MAIN_CLIENTS := sb3 sb3-batched torchrl torchrl-batched skrl skrl-ippo skrl-batched tianshou cleanrl batched
.venv-clients-%/.installed: pyproject.toml tests/clients/requirements-%.txt
	$(PYTHON) -m venv .venv-clients-$*
	.venv-clients-$*/bin/python -m pip install --quiet --upgrade pip
	.venv-clients-$*/bin/python -m pip install --quiet "$(TORCH)" || \
		.venv-clients-$*/bin/python -m pip install --quiet "$(TORCH)" --index-url https://download.pytorch.org/whl/cpu
	.venv-clients-$*/bin/python -m pip install --quiet -r tests/clients/requirements-$*.txt
	.venv-clients-$*/bin/python -m pip install --quiet -e .
	touch $@

test-clients: $(STAMP) $(RLLIB)/.installed $(foreach c,$(CLIENT_VENVS),.venv-clients-$(c)/.installed)
	FLATLAND_CLIENTS="$(MAIN_CLIENTS)" $(BIN)/python -m pytest -q -p no:cacheprovider tests/clients
	FLATLAND_CLIENTS=rllib $(RLLIB)/bin/python -m pytest -q -p no:cacheprovider tests/clients
	for c in $(CLIENT_VENVS); do \
		FLATLAND_CLIENTS=$$c .venv-clients-$$c/bin/python -m pytest -q -p no:cacheprovider tests/clients || exit 1; \
	done

# A million agent-steps of fruits_poisons_multi and 500 env creations in one process: RSS
# and agent-steps/s at start and end, growth after warm-up (tests/soak.py; fails at 5%).
soak: $(STAMP)
	$(BIN)/python -m tests.soak

# The single envs beside bare physics, then the batched env at scale and PPO end to end.
bench: $(STAMP)
	$(BIN)/flatland-ma bench
	$(BIN)/flatland-ma bench --scale

# The learner against its parts (baselines/benchmark/learner_speed.py): the env, the acting
# pass and the update each alone, then baselines.ppo serial and overlapped, in agent-steps per
# CPU-second, on the one-agent and the four-agent room and on signal_rooms' maps.
bench-learn: $(STAMP)
	$(BIN)/python -m baselines.benchmark.learner_speed --scenario fruits_poisons
	$(BIN)/python -m baselines.benchmark.learner_speed --scenario fruits_poisons_multi
	$(BIN)/python -m baselines.benchmark.learner_speed --scenario signal_rooms --loop-timesteps 32768

# A new `bench --scale --json` run into benchmarks/results/scale.json, then VMAS beside
# flatland_ma in the same run (benchmarks/peers.py, VMAS in .venv-vmas: its pins clash with
# ours), and docs/performance.md's tables of both (benchmarks/performance_table.py). Run it
# on a machine nothing else loads.
VMAS_VENV := .venv-vmas
$(VMAS_VENV)/.installed:
	$(PYTHON) -m venv $(VMAS_VENV)
	$(VMAS_VENV)/bin/python -m pip install --quiet "$(TORCH)" || \
		$(VMAS_VENV)/bin/python -m pip install --quiet "$(TORCH)" --index-url https://download.pytorch.org/whl/cpu
	$(VMAS_VENV)/bin/python -m pip install --quiet vmas==1.5.2
	touch $@

performance-page: $(STAMP) $(VMAS_VENV)/.installed
	$(BIN)/flatland-ma bench --scale --json > benchmarks/results/scale.json.part
	mv benchmarks/results/scale.json.part benchmarks/results/scale.json
	VMAS_PYTHON=$(VMAS_VENV)/bin/python $(BIN)/python -m benchmarks.peers
	$(BIN)/python -m benchmarks.performance_table

# The scenario format's reference and the JSON schema shipped for editors, both written
# from the models, and the shipped scenarios' index (what registering ids needs), from the
# files (tests/scenario/test_scenario_schema.py and tests/envs/test_registration_index.py check them).
reference: $(STAMP)
	$(BIN)/python -m flatland_ma.scenario.reference docs/scenarios.md scenarios/scenario.schema.json

# A shipped scenario's picture and animation (as `make docs` draws them) and the scores line
# of its header comment (random play and its reference solver), which the library tests
# require.
scenario-page: $(STAMP)
	@test -n "$(NAME)" || (echo "usage: make scenario-page NAME=<scenario>" && exit 2)
	$(BIN)/flatland-ma record $(NAME) --policy planner --steps 60 --seed 1 --out docs/images/scenarios/$(NAME).png
	$(BIN)/python docs/_ext/animations.py $(NAME)
	$(BIN)/python -m flatland_ma.policies.scores_header $(NAME)

# Pictures of the scenarios for the README and docs/ (after the format reference), and a
# short animation for every scenario page without a recording of its own (docs/images/animations).
docs: reference
	$(BIN)/flatland-ma record fruits_poisons --steps 240 --every 3 --seed 3 --out docs/images/fruits_poisons.gif
	$(BIN)/flatland-ma record fruits_poisons_multi --steps 120 --seed 3 --out docs/images/fruits_poisons_multi.png
	$(BIN)/flatland-ma record fruits_poisons_multi --sensors camera,lidar,proprioception --steps 60 --seed 3 \
		--out docs/images/render_senses.png
	SDL_VIDEODRIVER=dummy $(BIN)/flatland-ma play fruits_poisons_multi --seed 3 --fps 0 \
		--keys "up*25 left*8 up*20 tab up*12" --screenshot docs/images/play_window.png
	for s in $$($(BIN)/python -c "import flatland_ma; print(' '.join(flatland_ma.list_scenarios()))"); do \
		$(BIN)/flatland-ma record $$s --policy planner --steps 60 --seed 1 --out docs/images/scenarios/$$s.png || exit 1; \
	done
	for s in push_box fetch_object key_carry coop_carry tug_of_war; do \
		$(BIN)/flatland-ma record $$s --policy carrier --steps 300 --every 3 --seed 1 --out docs/images/tasks/$$s.gif || exit 1; \
	done
	$(BIN)/flatland-ma record scent_rooms --policy sniffer --steps 300 --every 3 --seed 1 --out docs/images/tasks/scent_rooms.gif
	$(BIN)/python docs/_ext/animations.py

# The documentation site in docs/_build/html (the docs extra in .venv): the catalogue pages
# are written from the shipped scenario, stream and suite files and the tutorials run at
# every build; any warning fails it. docs-check opens every page in headless Chromium
# (Debian's chromium package) and saves the README's screenshots (tests/docs/).
DOCS_STAMP := $(VENV)/.docs-installed
$(DOCS_STAMP): $(STAMP)
	$(BIN)/python -m pip install --quiet -e ".[docs]"
	touch $(DOCS_STAMP)

docs-site: $(DOCS_STAMP)
	$(BIN)/sphinx-build -W --keep-going -b html docs docs/_build/html

docs-check: docs-site
	$(BIN)/python -m pytest -q -p no:cacheprovider tests/docs

# The studio's pages (flatland-ma studio): built from studio/frontend (Vite, CodeMirror,
# package-lock.json pinned) into flatland_ma/studio/static, which is committed and shipped
# as package data, so an install needs no npm. studio-check opens them in headless
# Chromium (Debian's, through the docs extra's Playwright) and saves docs/images/studio/.
studio-assets:
	cd studio/frontend && npm ci --no-audit --no-fund && npx vite build

studio-check: $(DOCS_STAMP)
	$(BIN)/python -m pytest -q -p no:cacheprovider tests/studio/pages

# The paper's experiment: DQN, A3C and DFP on fruits_poisons, SEEDS seeds of 250k steps
# each, WORKERS seeds at a time (runs/ resumes where it stopped); A3C also with lr 1e-4,
# universe-starter-agent's own default. Then the figure and table (docs/results.md).
SEEDS ?= 30
WORKERS ?= 2
reproduce: $(STAMP)
	$(BIN)/python -m baselines.run dqn --seeds $(SEEDS) --workers $(WORKERS) --steps 250000 --out runs
	$(BIN)/python -m baselines.run dfp --seeds $(SEEDS) --workers $(WORKERS) --steps 250000 --out runs
	$(BIN)/python -m baselines.run a3c --seeds $(SEEDS) --workers 1 --steps 250000 --out runs
	$(BIN)/python -m baselines.run a3c --name a3c_lr1e-4 --seeds $(SEEDS) --workers 1 \
		--steps 250000 --out runs -- --learning-rate 1e-4
	$(MAKE) results

RUNS ?= runs
results: $(STAMP)
	$(BIN)/python -m baselines.benchmark.plot $(RUNS)/dqn/fruits_poisons $(RUNS)/a3c/fruits_poisons \
		$(RUNS)/a3c_lr1e-4/fruits_poisons $(RUNS)/dfp/fruits_poisons \
		--labels DQN "A3C (lr 1e-5, the paper's)" "A3C (lr 1e-4)" DFP --references 20 \
		--out docs/images/results_fruits_poisons.png

# Shared-parameter PPO on the paper's room with four agents.
reproduce-multi: $(STAMP)
	$(BIN)/python -m baselines.run ppo --seeds 3 --workers $(WORKERS) --steps 1000000 --out runs
	$(BIN)/python -m baselines.benchmark.plot $(RUNS)/ppo/fruits_poisons_multi --labels "PPO (shared parameters)" \
		--by-agent --references 20 --out docs/images/results_fruits_poisons_multi.png

# Random, scripted and open-loop play and PPO on every shipped scenario and stream, one JSON
# per seed under results/benchmark/; done seeds are skipped, so it resumes. PPO's budgets and
# seeds come from the tier (baselines/benchmark/settings.yaml): TIER=smoke (100k x 3 seeds,
# the default), standard (1M x 5) or certificate (10M x 3, its listed tasks); hours of CPU
# beyond smoke. benchmark-table rebuilds docs/benchmark.md, the figures and each scenario's
# learning curve (docs/images/curves/) from the JSON alone.
TIER ?= smoke
benchmark: $(STAMP)
	nice -n 10 $(BIN)/python -m baselines.benchmark --tier $(TIER)
	$(MAKE) benchmark-table

benchmark-table: $(STAMP)
	$(BIN)/python -m baselines.benchmark.table

# Style (ruff) and types (pyright, configured in pyproject.toml: zero errors on flatland_ma/).
lint: $(STAMP)
	$(BIN)/ruff check flatland_ma baselines tests benchmarks scenarios docs/conf.py docs/_ext
	$(BIN)/ruff format --check flatland_ma baselines tests benchmarks scenarios docs/conf.py docs/_ext
	$(BIN)/pyright

clean:
	rm -rf $(VENV) $(RLLIB) .venv-clients-* $(VMAS_VENV) $(NEWEST_PYMUNK) demo .pytest_cache docs/_build docs/catalogue
