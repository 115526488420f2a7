# modal_twin: `make demo` runs the main job, `make test` the tests; both set up first.
.PHONY: setup demo test bench lint clean
PY := .venv/bin/python

setup:
	@bash tools/setup.sh

demo: setup
	@OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 $(PY) -m modal_twin.cli demo

test: lint
	@OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 $(PY) -m pytest -q -p no:cacheprovider --durations=25

bench: setup
	@for b in test/benchmarks/bench_*.py; do echo "== $$b"; OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 $(PY) $$b || exit 1; done

# The type and lint gate (offline: ruff and mypy run on the sources only, settings in
# pyproject.toml); `make test` runs it first and stops on any error.
lint: setup
	@.venv/bin/ruff check modal_twin test
	@.venv/bin/mypy modal_twin

clean:
	rm -rf build .venv *.egg-info
