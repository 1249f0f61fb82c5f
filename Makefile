# fotogeo — the two commands a newcomer runs: `make demo` and `make test`.
# Both set up everything themselves: Debian packages (as root), a virtual environment made
# from Debian's Python 3 with its system site-packages (so QGIS's Python bindings and
# fotogeo share one interpreter), and the Python packages pinned by constraints.txt.

SHELL := /bin/bash
SYSPY ?= /usr/bin/python3
VENV ?= .venv
PY := $(VENV)/bin/python
PIP := $(PY) -m pip --disable-pip-version-check -q
DEMO_OUT ?= out/demo
APT_BASE := python3 python3-venv python3-pip
APT_QGIS := $(APT_BASE) qgis python3-qgis qgis-providers
# the tests also run the real programs: qgis_process, and the desktop qgis on a virtual display
APT_TEST := $(APT_QGIS) gdal-bin xvfb xauth
QGIS_PROFILE ?= $(HOME)/.local/share/QGIS/QGIS3/profiles/default
APT_BENCH := $(APT_TEST) otb-bin

.PHONY: demo test test-plain docs bench plugin qgis-install clean system-base system-qgis system-test system-bench

define apt_install
	@missing=""; for p in $(1); do dpkg -s $$p >/dev/null 2>&1 || missing="$$missing $$p"; done; \
	if [ -n "$$missing" ]; then \
	  if [ "$$(id -u)" != 0 ]; then echo "fotogeo: need Debian packages:$$missing (run as root or: sudo apt-get install$$missing)"; exit 1; fi; \
	  echo "fotogeo: installing Debian packages:$$missing"; \
	  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends $$missing >/dev/null; \
	fi
endef

system-base:
	$(call apt_install,$(APT_BASE))

system-qgis:
	$(call apt_install,$(APT_QGIS))

system-test:
	$(call apt_install,$(APT_TEST))

system-bench:
	$(call apt_install,$(APT_BENCH))

$(VENV)/.created: | system-base
	$(SYSPY) -m venv --system-site-packages $(VENV)
	$(PIP) install -U "pip>=23"
	touch $@

$(VENV)/.installed: $(VENV)/.created pyproject.toml constraints.txt
	$(PIP) install -c constraints.txt -e ".[test]"
	touch $@

$(VENV)/.bench: $(VENV)/.installed
	$(PIP) install -c constraints.txt -e ".[test,bench]"
	touch $@

demo: $(VENV)/.installed
	$(VENV)/bin/fotogeo demo --output $(DEMO_OUT) --overwrite

# the fitting tests again on 1 and 2 BLAS threads: a fit must not depend on the caller's threads (issue 24)
FIT_TESTS := tests/test_models.py tests/test_models_lambda.py tests/test_models_spatial.py \
	tests/test_models_threads.py tests/test_rpc_refit.py

# the suite in TEST_WORKERS processes (pytest-xdist; the QGIS tests together in one of them: the scheduler in
# tests/conftest.py)
TEST_WORKERS ?= 2

test: system-test $(VENV)/.installed
	QT_QPA_PLATFORM=offscreen $(PY) -m pytest -q -n $(TEST_WORKERS)
	for n in 1 2; do echo "fitting tests on $$n BLAS thread(s)"; \
	  OPENBLAS_NUM_THREADS=$$n $(PY) -m pytest -q -p no:cacheprovider $(FIT_TESTS) || exit 1; done
	$(MAKE) test-plain

# The pip user's world: a plain venv (no system site-packages, no constraints.txt) from a non-Debian Python,
# `pip install .[test]` on today's wheels (numpy 2, OpenCV 5, rasterio 1.4), and the installed wheel tested
# (the pytest script, not `python -m pytest`, so the checkout's fotogeo/ is not on sys.path).
# A representative subset, not the whole suite (which runs above in the Debian venv): file formats, models,
# register, orient, the command line, ortho, the camera/option files and the packaging checks; the QGIS tests
# need Debian's python3-qgis and are not part of it. Measured (2 cores at load 15-20): the venv's first build
# about 10 min (wheels downloaded; again only when pyproject.toml changes), the subset 11.5 min (234 tests).
PLAIN_PY ?= $(shell for p in $$(pyenv root 2>/dev/null)/versions/3.12*/bin/python3.12 python3.12 python3.13 \
	python3.11 python3.10; do "$$p" -c "import sys, venv; assert sys.version_info >= (3, 10)" >/dev/null 2>&1 \
	&& { command -v "$$p"; break; }; done)
PLAIN_VENV ?= .venv-plain
PLAIN_TESTS := tests/test_io.py tests/test_io_exif.py tests/test_camera.py tests/test_options.py \
	tests/test_models.py tests/test_models_lambda.py tests/test_models_spatial.py \
	tests/test_register.py tests/test_register_bands.py tests/test_orient.py tests/test_compare_table.py \
	tests/test_cli.py tests/test_ortho.py tests/test_packaging.py tests/test_qt6_idioms.py tests/test_yaml_files.py \
	tests/test_cli_conventions.py tests/test_runtime_platforms.py tests/test_plugin_metadata.py
# the two slowest of them (bad-input and CRS/resampling sweeps of register, 3 of the subset's 11.5 min at load 15-20)
# run in the Debian venv only
PLAIN_DESELECT := --deselect tests/test_register.py::test_bad_inputs_give_clear_errors_and_no_output \
	--deselect tests/test_register.py::test_options_crs_resolution_resampling

$(PLAIN_VENV)/.installed: pyproject.toml
	@test -n "$(PLAIN_PY)" || { echo "fotogeo: test-plain needs python3.10-3.13 on PATH (pyenv install 3.12, or PLAIN_PY=...)"; exit 1; }
	$(PLAIN_PY) -m venv --clear $(PLAIN_VENV)
	$(PLAIN_VENV)/bin/python -m pip --disable-pip-version-check -q install -U pip
	$(PLAIN_VENV)/bin/python -m pip --disable-pip-version-check -q install ".[test]"
	touch $@

test-plain: $(PLAIN_VENV)/.installed
	$(PLAIN_VENV)/bin/python -m pip --disable-pip-version-check -q install --no-deps --force-reinstall .
	$(PLAIN_VENV)/bin/python -c "import fotogeo, numpy, cv2, rasterio; print('plain venv: fotogeo', fotogeo.__version__, 'numpy', numpy.__version__, 'opencv', cv2.__version__, 'rasterio', rasterio.__version__)"
	$(PLAIN_VENV)/bin/pytest -q -p no:cacheprovider -n $(TEST_WORKERS) -m "not qgis" $(PLAIN_DESELECT) $(PLAIN_TESTS)

# The documentation site (MkDocs-Material + mkdocstrings + mkdocs-click) from docs/ into site/, warnings as
# errors. A venv of its own (the docs extra on today's wheels), fotogeo installed editable so that mkdocs-click
# imports the commands and mkdocstrings reads the docstrings of this checkout.
DOCS_VENV ?= .venv-docs
$(DOCS_VENV)/.installed: pyproject.toml
	@test -n "$(PLAIN_PY)" || { echo "fotogeo: docs needs python3.10-3.13 on PATH (or PLAIN_PY=...)"; exit 1; }
	$(PLAIN_PY) -m venv --clear $(DOCS_VENV)
	$(DOCS_VENV)/bin/python -m pip --disable-pip-version-check -q install -e ".[docs]"
	touch $@

docs: $(DOCS_VENV)/.installed
	$(DOCS_VENV)/bin/mkdocs build --strict

bench: system-bench $(VENV)/.bench
	$(PY) benchmarks/register_bench.py
	$(PY) benchmarks/surf_bench.py
	$(PY) benchmarks/terrain_bench.py
	$(PY) benchmarks/orient_bench.py
	$(PY) benchmarks/matching_bench.py

clean:
	rm -rf $(VENV) $(PLAIN_VENV) $(DOCS_VENV) out dist build site *.egg-info

# The installable QGIS plugin: dist/fotogeo_qgis.zip (standard library only, no venv needed).
plugin:
	$(SYSPY) scripts/build_plugin.py

# fotogeo in a QGIS profile, ready to run: the plugin, its own runtime (a venv of binary wheels
# beside QGIS, never inside QGIS's process; see processing_provider/runtime.py), enabled.
# FOTOGEO_RUNTIME=<dir> puts the runtime elsewhere than <profile>/python/fotogeo-env.
qgis-install: system-qgis
	$(SYSPY) scripts/qgis_install.py --profile "$(QGIS_PROFILE)" $(if $(FOTOGEO_RUNTIME),--runtime "$(FOTOGEO_RUNTIME)")
