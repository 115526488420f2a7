# modal_twin: `make demo` runs the main job, `make test` the tests; both set up first.
.PHONY: setup demo test bench lint clean
PY := .venv/bin/python

setup:
	@bash tools/setup.sh

demo: setup
	@OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 $(PY) -m modal_twin.cli demo

# The tests run in WORKERS parallel processes (pytest-xdist), each test file whole on one
# worker (--dist loadfile: a file's module fixtures are built once). Every ROS graph reserves
# its own domain (modal_twin.domain), so the workers' graphs never meet.
WORKERS ?= 3
test: lint
	@OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 $(PY) -m pytest -q -p no:cacheprovider --durations=25 \
		-n $(WORKERS) --dist loadfile

bench: setup
	@for b in test/benchmarks/bench_*.py; do echo "== $$b"; OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 $(PY) $$b || exit 1; done

# The type and lint gate (offline: ruff and mypy run on the sources only, settings in
# pyproject.toml); `make test` runs it first and stops on any error.
lint: setup
	@.venv/bin/ruff check modal_twin test
	@.venv/bin/mypy modal_twin

clean:
	rm -rf build .venv *.egg-info
