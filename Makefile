# Each target sets up what is missing first: a .venv with bpy 5.0.1, numpy,
# pytest, the fast ray caster and the package in editable mode.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
WILDSCAN := $(VENV)/bin/wildscan
STAMP  := $(VENV)/.wildscan-installed
OUT    ?= out

.PHONY: setup demo test test-fast bench addon lint docs clean

setup: $(STAMP)
	@command -v qemu-x86_64 >/dev/null || echo "note: make test also needs Debian's qemu-user (sudo apt-get install qemu-user: scans on emulated older CPUs) and blender, xvfb, xauth, pcl-tools, cloudcompare, python3-rosbag (.ci/run installs them all); make test-fast needs none of them"

$(STAMP): pyproject.toml addon/wildscan/__init__.py
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet "bpy==5.0.1" numpy embreex matplotlib pytest pytest-xdist plyfile ruff \
		dask distributed laspy laszip tqdm pyyaml psutil rosbags open3d mkdocs mkdocs-material scikit-learn
	$(PY) -m pip install --quiet --no-deps -e .
	touch $(STAMP)

demo: $(STAMP)
	$(WILDSCAN) demo --seed 1 --out $(OUT)/demo

# two test processes (the machine's two cores), a test file's tests in one of them so its
# module fixtures are built once
test: $(STAMP)
	$(PY) -m pytest -q -n 2 --dist loadfile

# what a developer runs often (under 90 s on two cores): no Blender binary, no Xvfb, no
# external readers, nothing marked slow
FAST_TESTS := not blender_binary and not gui and not external and not slow
test-fast: $(STAMP)
	$(PY) -m pytest -q -n 2 -m "$(FAST_TESTS)"

bench: $(STAMP)
	$(WILDSCAN) bench --out $(OUT)/bench

addon: $(STAMP)
	$(PY) tools/build_addon.py

# the documentation site (mkdocs.yml): strict, so a broken link fails
docs: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(VENV)/bin/mkdocs build --strict --quiet --site-dir site

lint: $(STAMP)
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .

clean:
	rm -rf $(OUT) dist site
