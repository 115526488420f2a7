# modal_twin: `make demo` runs the main job, `make test` the tests; both set up first.
.PHONY: setup demo test bench lint clean
PY := .venv/bin/python

setup:
	@bash tools/setup.sh

demo: setup
	@OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 $(PY) -m modal_twin.cli demo

test: setup
	@OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 $(PY) -m pytest -q -p no:cacheprovider

bench: setup
	@for b in test/benchmarks/bench_*.py; do echo "== $$b"; OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 $(PY) $$b || exit 1; done

lint: setup
	@.venv/bin/ruff check modal_twin test

clean:
	rm -rf build .venv *.egg-info
