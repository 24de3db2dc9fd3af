# The two commands a fresh machine needs (see README): `make main` and `make test`.
# Both create .venv and install the project into it first; nothing is installed by hand.
VENV ?= .venv
PY := $(VENV)/bin/python
OUT ?= results
# pytest workers for `make test`: the project's machine has 2 cores and most tests are one
# single-threaded simulation each (TEST_WORKERS=0 runs the suite in one process). A test file goes
# to one worker (--dist loadfile), so its module fixtures (a whole simulated run) are built once.
TEST_WORKERS ?= 2

.PHONY: main test bench install clean

install: $(VENV)/.installed

# A failed install names the disk space too: a full disk fails deep inside pip (Errno 28).
INSTALL_FAILED = { echo "make: installing into $(VENV) failed (pip's message above); it needs about 3 GB of disk and $$(df -h $(dir $(abspath $(VENV))) | awk 'NR==2 {print $$4}') is free there: free some, or give VENV=DIR on a larger disk" >&2; exit 1; }

$(VENV)/.installed: setup.cfg pyproject.toml
	python3 -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip || $(INSTALL_FAILED)
	# torch first and pinned: the CPU build (a range would pull a multi-GB CUDA build).
	$(PY) -m pip install --quiet torch==2.13.0 || $(INSTALL_FAILED)
	$(PY) -m pip install --quiet -e '.[test,hardware,ray,viz]' || $(INSTALL_FAILED)
	touch $@

# A fresh folder per run (results/explore-YYYYMMDD-HHMMSS): a recorded run is never overwritten,
# so `make main` can be run again; continue a stopped one with tactile-explore --out DIR --resume.
main: install
	$(VENV)/bin/tactile-explore --out $(OUT)/explore-$$(date +%Y%m%d-%H%M%S)

test: install
	$(PY) -m ruff check .
	$(VENV)/bin/lint-imports
	$(PY) -m pytest -n $(TEST_WORKERS) --dist loadfile

bench: install
	$(PY) -m pytest -m slow

clean:
	rm -rf $(VENV) $(OUT)
