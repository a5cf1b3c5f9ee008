"""A specimen of your own, meshed with gmsh's Python API: a glass plate with an edge notch
pulled apart (the worked example of docs/scenes.md#your-own-mesh).

Run it from this folder to write ``notched_plate.msh``, which ``notched_plate.toml`` reads:

    python notched_plate.py

A plate of 10 mm x 10 mm (2D, plane stress) with a notch 2 mm deep and 0.2 mm wide from the
middle of its left edge. The mesh is fine (0.05 mm) in a band 1 mm high along the notch's
line, where the crack will run, and coarse (0.5 mm) elsewhere. What the scene uses are the
physical groups, by name: the curves "bottom" (held) and "top" (pulled), and the surface
"plate" (every cell must belong to some surface; its name is not used by this scene).
"""

import gmsh

WIDTH, HEIGHT = 10.0, 10.0              # mm
NOTCH_DEPTH, NOTCH_WIDTH = 2.0, 0.2     # mm
H_FINE, H_COARSE, BAND = 0.05, 0.5, 1.0  # mm: element sizes, height of the fine band


def main(path="notched_plate.msh"):
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.model.add("notched_plate")
    geo = gmsh.model.geo
    y0, y1 = HEIGHT / 2 - NOTCH_WIDTH / 2, HEIGHT / 2 + NOTCH_WIDTH / 2
    outline = [(0, 0), (WIDTH, 0), (WIDTH, HEIGHT), (0, HEIGHT), (0, y1), (NOTCH_DEPTH, y1),
               (NOTCH_DEPTH, y0), (0, y0)]
    points = [geo.addPoint(x, y, 0.0) for x, y in outline]
    lines = [geo.addLine(points[i], points[(i + 1) % len(points)]) for i in range(len(points))]
    surface = geo.addPlaneSurface([geo.addCurveLoop(lines)])
    geo.synchronize()
    gmsh.model.addPhysicalGroup(1, [lines[0]], name="bottom")
    gmsh.model.addPhysicalGroup(1, [lines[2]], name="top")
    gmsh.model.addPhysicalGroup(2, [surface], name="plate")
    # fine elements in the band around the notch's line, coarse elsewhere
    box = gmsh.model.mesh.field.add("Box")
    for key, value in (("VIn", H_FINE), ("VOut", H_COARSE), ("XMin", 0.0), ("XMax", WIDTH),
                       ("YMin", HEIGHT / 2 - BAND / 2), ("YMax", HEIGHT / 2 + BAND / 2), ("Thickness", 1.0)):
        gmsh.model.mesh.field.setNumber(box, key, value)
    gmsh.model.mesh.field.setAsBackgroundMesh(box)
    for key in ("Mesh.MeshSizeExtendFromBoundary", "Mesh.MeshSizeFromPoints", "Mesh.MeshSizeFromCurvature"):
        gmsh.option.setNumber(key, 0)
    gmsh.model.mesh.generate(2)
    gmsh.write(path)
    gmsh.finalize()


if __name__ == "__main__":
    main()
