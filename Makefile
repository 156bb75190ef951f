# The two commands a newcomer needs:
#   make demo   set up everything, render every preset into out/demo/ and draw a contact sheet
#   make test   set up everything and run the test suite
# Both work on a fresh Debian machine as root (they apt-get the Mesa EGL/OSMesa libraries).

PYTHON    ?= python3
VENV      ?= .venv
PY        := $(VENV)/bin/python
PIP       := $(PY) -m pip
SYS_PKGS  := python3-venv libegl1 libegl-mesa0 libgl1-mesa-dri libopengl0 libgles2 libosmesa6 libglu1-mesa \
             g++ make libpng++-dev tcsh chromium
PYTEST_ARGS ?=

.PHONY: demo test setup system venv bench clean

demo: setup
	$(VENV)/bin/stereoforge demo --out out/demo --overwrite

test: setup
	$(PY) -m pytest $(PYTEST_ARGS)

setup: system venv

# System libraries for headless OpenGL, and the compilers/libraries the tests need to build the
# real stereo tools of ../shared/clients (MiddEval3 SDK: g++, libpng; its runeval: tcsh; KITTI
# devkit: libpng++), and headless Chromium, which opens a validate report.html in a test (no
# broken image). Skipped when already installed.
system:
	@if dpkg -s $(SYS_PKGS) >/dev/null 2>&1; then \
	  echo "system packages present: $(SYS_PKGS)"; \
	else \
	  SUDO=""; [ "$$(id -u)" = 0 ] || SUDO=sudo; \
	  $$SUDO apt-get update && \
	  DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y --no-install-recommends $(SYS_PKGS); \
	fi

# The virtual environment is rebuilt only when pyproject.toml changes.
venv: $(VENV)/.installed

$(VENV)/.installed: pyproject.toml
	@$(PYTHON) -c 'import sys; sys.exit(sys.version_info < (3, 11))' || \
	  { echo "stereoforge needs Python >= 3.11 (found $$($(PYTHON) --version))"; exit 1; }
	$(PYTHON) -m venv $(VENV)
	$(PIP) install --quiet --upgrade pip
	$(PIP) install --quiet -e '.[test,learn]'
	touch $@

bench: setup
	$(VENV)/bin/stereoforge bench render
	$(VENV)/bin/stereoforge bench match

clean:
	rm -rf $(VENV) out build *.egg-info src/*.egg-info .pytest_cache .hypothesis
