"""`wildscan bench`: speed and accuracy of every ray backend, side by side, and the time it
takes to build a world (bpy wheel). One module per suite:

  testworld.py    one full r_h = 1 deg scan of the test world per backend, placement to PLY
                  written, split into phases: placement, beam directions, ray casting,
                  labels + leveling, PLY write. Says what dominates.
  primitives.py   range error against analytic ground truth on a tilted plane, a box, a
                  UV-sphere polyhedron and a 48-sided prism, in closed form.
  levels.py       the default world at each detail level, from the first valid pose of each
                  zone: scan time, per-ray label and range agreement with scene.ray_cast, the
                  terrain's height error against the analytic heightfield. One FULL
                  scene.ray_cast scan is timed, so the headline ratio is measured.
  scaling.py      scan time against beams (r_h 4 -> 0.25 deg), triangles (detail levels) and
                  objects (synthetic scenes of N objects).
  world_build.py  the world built at each detail level: stage times, counts, terrain fit
                  (suite "world"; `wildscan bench-world`).
  realism.py      porous vegetation and the realistic sensor model (suite "realism"): crown and
                  canopy gap fractions (porosity.py), echoes, realistic scan speed beside the
                  paper model's, world build time and memory porous beside solid.
  targets.py      each speed and accuracy goal of the benchmark, met or not.
  devices.py      every device preset's full-frame scan beside Embree's own cast of the same
                  rays (suite "devices").
  casters.py      every float32 ray caster on the same sealed triangles and rays: build,
                  memory, rays/s, same PLY bytes (suite "casters"; the candidates that are
                  not backends are in caster_candidates.py).

backends.py runs the first four (suite "backends", the default) and writes bench.csv,
bench.png and scaling.md (report.py); config.py holds what a run measures, measure.py the
timing and agreement helpers.

scene.ray_cast is slow (its cost a ray grows with the objects), so elsewhere it casts
--reference-rays rays spread evenly over each scan and its full-scan time is extrapolated
(marked '~'). Every disagreement with it is judged against the exact float64 brute force
(raycast.geometry.check_hits) to say whose answer is wrong. Timings run with the garbage
collector paused, as timeit does.

Everything is built in scenes of its own, removed afterwards: the user's scenes are never
touched. Results: bench.csv, bench.png and scaling.md in --out (written together, all or none).

    wildscan bench [--quick] [--details low,default,high] [--backends embree,bvh] [--out DIR]
    wildscan bench --suite world [--seed S] [--details LIST]      (= wildscan bench-world)
    wildscan bench --suite realism [--seed S] [--quick]
    wildscan bench --suite devices [--seed S] [--quick] [--markdown docs/benchmarks.md]
    wildscan bench --suite casters [--seed S] [--quick] [--markdown docs/benchmarks.md]
"""
