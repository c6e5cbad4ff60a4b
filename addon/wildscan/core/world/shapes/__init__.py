"""Few-polygon meshes for both worlds (numpy only), one module per family.

Every shape is a (vertices (V,3) float64, faces (F,3) int32) pair, triangles
wound counter-clockwise seen from outside. An element's shape is in its local
frame: origin on the ground at the element's foot, Z up, X the element's
heading; it is built once per world as a shared prototype that instances only
move, turn and scale.

Modelling rule: no more detail than the sensor can resolve (15 m range,
0.25 deg between beams: ~6.5 cm at 15 m) and nothing hidden inside something
else: a trunk or branch stops just inside its crown, a rock or bush loses the
faces that lie wholly below the ground.

    primitives   box, tube, cylinder, cone, spheres, lathe, grids, discs; merge, transform, ...
    trees        conifer, broadleaf, birch (trunk and crown apart)
    plants       bushes and grass tufts
    rocks        faceted stones
    furniture    picnic table, bench, fence
    powerline    pole, catenary, wire
"""
