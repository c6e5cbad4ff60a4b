"""The Blender side (bpy; thin): realise a world plan as tagged objects, build the test
world, open and save .blend files. Importing this package itself needs no bpy."""

# The collection WildScan builds its world into; a rebuild replaces what it made there.
WORLD_COLLECTION = "WildScan"
