"""What the tests share: helper modules (imported as tests.helpers.NAME) and the scripts
some tests run in a subprocess or inside Blender (determinism_probe.py, open3d_probe.py,
visibility_probe.py; golden_cases.py also rewrites tests/golden/)."""
