# mane: two commands set everything up on a fresh Debian/Ubuntu machine.
#   make demo   the main job       make test   the test suite
#   make test-fast   the suite without the tests marked slow (pytest -m 'not slow')
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
APT_PKGS := libegl1 libegl-mesa0 libgl1 libgl1-mesa-dri libgles2 xvfb xauth

.PHONY: demo test test-fast system-deps install clean

demo: $(STAMP)
	$(VENV)/bin/mane demo

test: $(STAMP)
	$(PY) -m pytest -q --durations=15

test-fast: $(STAMP)
	$(PY) -m pytest -q -m 'not slow'

install: $(STAMP)

# Mesa's EGL and DRI drivers give a full OpenGL 4.5 (llvmpipe) without a GPU; Xvfb runs the window tests.
system-deps:
	@missing=""; \
	ldconfig -p | grep -q 'libEGL.so.1 ' || missing="$$missing libegl1"; \
	ldconfig -p | grep -q 'libEGL_mesa.so.0 ' || missing="$$missing libegl-mesa0"; \
	ldconfig -p | grep -q 'libGL.so.1 ' || missing="$$missing libgl1"; \
	ls /usr/lib/*/dri/swrast_dri.so /usr/lib/dri/swrast_dri.so >/dev/null 2>&1 || missing="$$missing libgl1-mesa-dri"; \
	command -v Xvfb >/dev/null 2>&1 || missing="$$missing xvfb xauth"; \
	if [ -n "$$missing" ]; then \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
	    echo "mane: installing system packages:$$missing"; \
	    DEBIAN_FRONTEND=noninteractive apt-get update -qq && \
	    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends $(APT_PKGS) >/dev/null; \
	  else \
	    echo "mane: missing system packages:$$missing"; \
	    echo "      install them with: sudo apt-get install $(APT_PKGS)"; exit 1; \
	  fi; \
	fi

$(STAMP): pyproject.toml | system-deps
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[test]'
	touch $(STAMP)

clean:
	rm -rf $(VENV) out .pytest_cache .hypothesis
