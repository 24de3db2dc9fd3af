# The two commands a fresh machine needs (see README): `make main` and `make test`.
# Both create .venv and install the project into it first; nothing is installed by hand.
VENV ?= .venv
PY := $(VENV)/bin/python
OUT ?= results

.PHONY: main test bench install clean

install: $(VENV)/.installed

$(VENV)/.installed: setup.cfg pyproject.toml
	python3 -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	# torch first and pinned: the CPU build (a range would pull a multi-GB CUDA build).
	$(PY) -m pip install --quiet torch==2.13.0
	$(PY) -m pip install --quiet -e '.[test,hardware,ray,viz]'
	touch $@

main: install
	$(VENV)/bin/tactile-explore --out $(OUT)/explore

test: install
	$(PY) -m pytest

bench: install
	$(PY) -m pytest -m slow

clean:
	rm -rf $(VENV) $(OUT)
