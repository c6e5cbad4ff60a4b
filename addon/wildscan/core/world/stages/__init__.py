"""The world's stages, one module each, run in order by pipeline.py:

    layout -> terrain -> poses -> trail, lake, cave, trees, bushes, rocks, grass, park, powerline

A stage module has a `STAGE` name and `run(plan, rng)`, where `rng` is its own
generator `stage_rng(seed, "world.<STAGE>")`, and owns everything about its
element or zone: its parameters dataclass (collected by WorldParams), its
shape (drawn during the layout stage, in a fixed order), how that shape bends
the terrain, where it keeps other elements and scan poses out, which scan
sites it offers, its placements, and how world.json describes its zone.
"""
