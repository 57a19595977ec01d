# EigenMPM for YADE. `make demo` and `make test` install what is missing (Debian packages),
# build, then run. Other targets: build, bench, reference-doc, clean.
SHELL := /bin/bash
PYTHON := /usr/bin/python3.11
BUILD := build
JOBS ?= $(shell nproc)
DEBS := yade cmake make g++ libeigen3-dev libboost-python1.74-dev libboost-numpy1.74-dev \
        python3-dev python3.11-dev libgtest-dev python3-pytest python3-numpy python3-matplotlib \
        python3-vtk9 python3-scipy openmpi-bin libopenmpi-dev python3-mpi4py
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)
export PYTHONPATH := $(CURDIR)/$(BUILD)/python$(if $(PYTHONPATH),:$(PYTHONPATH))

.PHONY: deps build demo test bench clean reference reference-doc

deps:
	@missing=$$(for p in $(DEBS); do dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q "ok installed" || echo $$p; done); \
	if [ -n "$$missing" ]; then \
	  echo "Installing Debian packages:" $$missing; \
	  $(SUDO) apt-get update -qq && DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq $$missing; \
	fi

build: deps
	cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release -DPython3_EXECUTABLE=$(PYTHON) > /dev/null
	cmake --build $(BUILD) -j $(JOBS)

# The quick crack-branching plate (paper Section 5.2, h = 1 mm, 16 000 points, 40 us): about
# 10 s after the build.
demo: build
	yade -n -x examples/crack_branching.py --quick --out out/demo
	@echo "Demo done: dynamic crack branching in a glass plate (examples/crack_branching.py --quick)"
	@echo "  damage map       out/demo/damage.png"
	@echo "  energies         out/demo/energy.png"
	@echo "  crack tip speed  out/demo/tip_speed.png"
	@echo "  numbers          out/demo/summary.json (VTK series for ParaView in out/demo/vtk/)"

test: build
	cd $(BUILD) && ctest --output-on-failure -j $(JOBS)
	$(PYTHON) -m pytest tests/python -q

bench: build
	bash bench/run.sh

# Re-record the regression references examples/reference/NAME.json from runs on this machine
# (values only; the tolerances stay): make reference NAMES="crack_branching lshaped_panel"
reference: build
	$(PYTHON) tools/regression.py record $(NAMES)

# Regenerate the parameter reference doc/reference/*.md from the declarations in py/eigenmpm
# (tests/python/test_param_reference.py fails while a committed page is stale)
reference-doc: build
	PYTHONPATH=$(PYTHONPATH):$(YADE_PY) $(PYTHON) tools/paramdoc.py

clean:
	rm -rf $(BUILD) out
