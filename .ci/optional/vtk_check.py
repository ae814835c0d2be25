"""Optional check (not run by .ci/run): a run's VTK series read by the VTK library itself (the readers ParaView
uses), from the `vtk` wheel.

    python3 -m venv /tmp/vtk && /tmp/vtk/bin/pip install vtk
    /tmp/vtk/bin/python .ci/optional/vtk_check.py RUN_DIR

Checks that animation.pvd lists the frames of summary.json at their times, that every frame reads as a
triangle grid with the point data velocity, strain, contact_pressure and uv, that the last frame spans the run's
final height range, and that vtk/obstacles.vtu reads. Exit status 1 on a failed check.
"""

import json
import sys
import xml.etree.ElementTree as ET

import vtk

run = sys.argv[1]
summary = json.load(open(f"{run}/summary.json"))
failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)


sets = ET.parse(f"{run}/animation.pvd").getroot().find("Collection").findall("DataSet")
times = [float(e.get("timestep")) for e in sets]
check(len(times) == len(summary["frames"]) and all(abs(a - f["time"]) < 1e-9 for a, f in zip(times, summary["frames"])),
      f"animation.pvd lists {len(times)} frames at the run's times")
last = None
for e in sets:
    r = vtk.vtkXMLUnstructuredGridReader()
    r.SetFileName(f"{run}/{e.get('file')}")
    r.Update()
    g = r.GetOutput()
    names = {g.GetPointData().GetArrayName(i) for i in range(g.GetPointData().GetNumberOfArrays())}
    ok = g.GetNumberOfCells() > 0 and all(g.GetCellType(i) == vtk.VTK_TRIANGLE for i in range(g.GetNumberOfCells()))
    check(ok and {"velocity", "strain", "contact_pressure", "uv"} <= names, f"{e.get('file')}: {g.GetNumberOfPoints()} points, triangles, {sorted(names)}")
    last = g
z0, z1 = last.GetBounds()[4:6]
final = summary["final"]
check(abs(z0 - final["bbox_min"][2]) < 1e-4 and abs(z1 - final["bbox_max"][2]) < 1e-4, f"the last frame spans z {z0:.4f} .. {z1:.4f} m")
o = vtk.vtkXMLUnstructuredGridReader()
o.SetFileName(f"{run}/vtk/obstacles.vtu")
o.Update()
check(o.GetOutput().GetNumberOfCells() > 0, f"vtk/obstacles.vtu: {o.GetOutput().GetNumberOfCells()} triangles")
sys.exit(1 if failures else 0)
