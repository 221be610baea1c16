# Two entry points (README quick start): `make report` and `make test`.
# Both prepare the machine first (scripts/setup.sh: system libraries + .venv).
VENV := .venv
BIN := $(VENV)/bin
OUT ?= runs/report

.PHONY: setup report report-media test test-fast lint docs doctor animate frames sweep sweep-variants sweep-best sweep-density gate gate-baseline lower-bounds clean

setup:
	@bash scripts/setup.sh

# The accuracy report; with the gate's baseline, a sweep (SWEEP, default the standard
# sweep's store), the animations `make animate` measured (runs/animate/*) and other renderers
# that `volcaustics compare` measured (runs/compare/NAME/SCENE) when they exist.
SWEEP ?= runs/sweep
ANIMATIONS = $$(for d in runs/animate/*/; do [ -f "$$d/summary.json" ] && echo --animation "$$d"; done)
COMPARISONS = $$(for d in runs/compare/*/; do ls "$$d"*/summary.json >/dev/null 2>&1 && echo --compare "$$(basename "$$d")=$$d"; done)
report: setup
	$(BIN)/volcaustics report --out $(OUT) \
	  $$( [ -f $(GATE_BASELINE)/baseline.json ] && echo --baseline $(GATE_BASELINE) ) \
	  $$( [ -f $(SWEEP)/sweep.json ] && [ -f $(SWEEP)/points.parquet ] && echo --sweep $(SWEEP) ) \
	  $$( [ -f $(FRAMES)/frames.json ] && echo --frames $(FRAMES) ) \
	  $(ANIMATIONS) $(COMPARISONS)

# The media scenes (scenes/media: fogbank, smoke; heterogeneous media) with budgets of their own:
# a report like the main one -> runs/report-media, about 4 minutes cold on 2 cores (2026-12-06).
report-media: setup
	$(BIN)/volcaustics report --scenes fogbank,smoke --budgets $(MEDIA_BUDGETS) --out runs/report-media

# The frame check: the paper's configuration against --preset best and --preset beams on every
# built-in and held-out scene, one frame and the mean, without and with OIDN -> runs/frames (the
# report's "One frame" section); 35 minutes on 2 cores with four of the twelve references cold (2026-12-05),
# a few more since the held-out layered_fog joined (2026-12-06). The media scenes by name:
# $(BIN)/volcaustics frames fogbank smoke (10 minutes, references cached).
FRAMES ?= runs/frames
MEDIA_BUDGETS = reports/studies/gate/media_budgets.toml
frames: setup
	$(BIN)/volcaustics frames -o $(FRAMES)

# The built-in animations over time (bunny, refocus, two_spheres) -> runs/animate/NAME;
# resumable; about 3 minutes each cold on 2 cores.
animate: setup
	for s in bunny refocus two_spheres; do $(BIN)/volcaustics animate $$s -o runs/animate/$$s || exit $$?; done

# Everything, the slow statistical and browser tests included (what CI runs).
test: setup
	@bash scripts/setup.sh --browser
	@bash scripts/run_tests.sh

# The inner loop: the suite without the tests marked slow (pytest -m "not slow"); its GL-call
# tests need apitrace, which --browser installs with the browser and Node tools of make test
# (once; a fresh machine's test-fast errored without it).
test-fast: setup
	@bash scripts/setup.sh --browser
	@bash scripts/run_tests.sh -m "not slow"

# ruff (pyproject.toml [tool.ruff]), the reference check (every path, module name and docs
# section named anywhere exists), the import-resolution check (mypy follows every
# volcaustics.* import of the package and its tests; its rules limited to imports), mypy on
# the package with pyproject.toml's [tool.mypy] (0 errors), the annotation check (every
# public function annotates its parameters and return), the private-name check (no module
# imports or reaches another module's _name) and the shader check (every program variant
# under glslangValidator).
lint: setup
	$(BIN)/ruff check .
	$(BIN)/python scripts/check_references.py
	$(BIN)/python scripts/check_imports.py
	$(BIN)/python -m mypy -p volcaustics
	$(BIN)/python scripts/check_annotations.py
	$(BIN)/python scripts/check_sizes.py
	$(BIN)/python scripts/check_private_names.py
	$(BIN)/python scripts/check_shaders.py

# The documentation site (MkDocs, Material theme) -> runs/site, strictly: a broken link, a
# stale reference or a missing page fails it. The command reference is generated from the
# parsers as the site builds (scripts/docs_hook.py).
docs: setup
	$(BIN)/python scripts/check_references.py
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict --quiet

doctor: setup
	$(BIN)/volcaustics doctor

# The regression gate on the built-ins: budgets (reports/studies/gate/budgets.toml) and, once a
# baseline is accepted (`make gate-baseline`), the regression test against it.
GATE_BASELINE ?= gate-baseline
gate: setup
	$(BIN)/volcaustics gate --render-references --junit runs/gate/junit.xml \
	  $$( [ -f $(GATE_BASELINE)/baseline.json ] && echo --baseline $(GATE_BASELINE) ) \
	  $(ANIMATIONS)

gate-baseline: setup
	$(BIN)/volcaustics gate --render-references --baseline $(GATE_BASELINE) --update-baseline

# The standard sweep: every built-in x layers x iterations at the quick preset, one seed.
sweep: setup
	$(BIN)/volcaustics sweep --vary layers=1,2,4,8 --vary iterations=4,8,16,30 -o runs/sweep

# The variants sweep: every built-in x search x start_rule x layer_strategy x budgets
# (reports/studies/sweep/variants.toml), quick preset, 4 seeds; resumable. The report shows it.
sweep-variants: setup
	$(BIN)/volcaustics sweep reports/studies/sweep/variants.toml -o runs/sweep-variants

# The density sweep (reports/studies/sweep/density.toml): sphere1 and bunny from haze to thick fog,
# the approximation's error and the single-scattering model's against optical depth; resumable.
sweep-density: setup
	$(BIN)/volcaustics sweep reports/studies/sweep/density.toml -o runs/sweep-density

# The best-configuration search (reports/studies/best/best.toml): every configuration at the paper
# configuration's frame cost, coarse grid then refinement, on every built-in; resumable.
sweep-best: setup
	$(BIN)/volcaustics sweep --best -o runs/sweep-best

# The dependency ranges at their lower bounds: a second venv (.venv-lower) with every
# pyproject requirement pinned to its ">=" version, pip check, then the test suite there.
lower-bounds: setup
	$(BIN)/python bench/lower_bounds.py

clean:
	rm -rf runs test-output .pytest_cache .hypothesis
