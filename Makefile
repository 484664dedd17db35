# Two entry points: `make demo` (install + end-to-end run) and `make test` (install + tests).
PYTHON ?= python3
VENV   ?= .venv
BIN     = $(VENV)/bin
STAMP   = $(VENV)/.installed-stamp
DEMO_DIR ?= build/demo

.PHONY: demo test test-all lint bench docs study clean serve

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

# `photomodel warmup --all` compiles every numba kernel into the cache first, in parallel
# processes, with progress (seconds when they are cached already).
demo: $(STAMP)
	$(BIN)/photomodel warmup --all
	$(BIN)/photomodel demo --out $(DEMO_DIR) --seed 3

test: $(STAMP)
	$(BIN)/photomodel warmup --all
	$(BIN)/python -m pytest -m "not slow" -q

test-all: $(STAMP)
	$(BIN)/python -m pytest -q

lint: $(STAMP)
	$(BIN)/ruff check src tests benchmarks

bench: $(STAMP)
	$(BIN)/python benchmarks/bench_fitness.py
	$(BIN)/python benchmarks/bench_sim.py

# The paper's accuracy study (12 garments, paper conditions); resumable, extend with more TRIALS.
TRIALS ?= 10
study: $(STAMP)
	$(BIN)/photomodel experiment --out build/study-paper --garments all --trials $(TRIALS) \
		--conditions paper --seed 0

# Contact sheets of the simulator (committed under docs/): every garment, every nuisance.
docs: $(STAMP)
	$(BIN)/photomodel simulate --out build/docs/garments --garments all --conditions paper \
		--seed 7 --force --contact-sheet docs/sim_garments.png
	$(BIN)/photomodel simulate --out build/docs/nuisances --garments No.1 --conditions all \
		--seed 7 --force --contact-sheet docs/sim_nuisances.png
	$(BIN)/photomodel simulate --out build/docs/lenses --garments No.1 \
		--conditions wide-lens --seed 7 --force --contact-sheet docs/sim_wide_lens.png
	$(BIN)/python scripts/bad_inputs.py --out docs/bad-inputs.md

# The cell service on a small simulated cell: the dataset and the model library are made once,
# under $(SERVE_DIR) (delete it to start afresh); another port: `make serve PORT=8099`.
PORT ?= 8080
SERVE_DIR ?= build/serve
OPCUA_PORT ?= 4840
SERVE_GARMENTS ?= No.1,No.3,No.5
serve: $(STAMP) | $(SERVE_DIR)/models/index.json
	$(BIN)/photomodel serve --stereo $(SERVE_DIR)/data/stereo.yaml --models $(SERVE_DIR)/models \
		--camera $(SERVE_DIR)/data/model_camera.yaml --port $(PORT) --source sim:No.3 \
		--opcua $(OPCUA_PORT)

$(SERVE_DIR)/data/truth.json: | $(STAMP)
	$(BIN)/photomodel simulate --out $(SERVE_DIR)/data --garments $(SERVE_GARMENTS) --scenes 3 \
		--seed 3 --force

# every model is built before the library is made, so that a failed build leaves no library
$(SERVE_DIR)/models/index.json: | $(SERVE_DIR)/data/truth.json
	set -e; garments="$$(echo $(SERVE_GARMENTS) | tr , ' ')"; \
	for g in $$garments; do \
		$(BIN)/photomodel build --photo $(SERVE_DIR)/data/models/$$g/photo.bmp \
			--background $(SERVE_DIR)/data/models/$$g/background.bmp \
			--camera $(SERVE_DIR)/data/model_camera.yaml --out $(SERVE_DIR)/built/$$g.npz \
			--name $$g --no-preview; \
	done; \
	$(BIN)/photomodel models add --models $(SERVE_DIR)/models --replace \
		$$(for g in $$garments; do echo $(SERVE_DIR)/built/$$g.npz; done)

clean:
	rm -rf $(VENV) build .pytest_cache
