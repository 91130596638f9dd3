#!/usr/bin/env python3
"""Reads every .pvd of a dgsph output directory with VTK's own readers (an independent check of
the ParaView output) and verifies: each indexed .vtp opens, has the number of points of its run
(`<run>.run.json`: fluid + walls), one vertex per point, and the point fields velocity (3
components), pressure, density, det_f, free_surface, wall, all finite.

Usage: python3 scripts/check_vtk.py DIR   (pip install vtk)
"""
import json
import math
import os
import sys
import xml.etree.ElementTree as ET

# Only the XML readers: no rendering libraries (libGL, X11) are needed.
from vtkmodules.vtkCommonCore import vtkVersion
from vtkmodules.vtkIOXML import vtkXMLPolyDataReader
from vtkmodules.util.numpy_support import vtk_to_numpy

FIELDS = {"velocity": 3, "pressure": 1, "density": 1, "det_f": 1, "free_surface": 1, "wall": 1}


def check_run(directory, pvd):
    run = pvd[: -len(".pvd")]
    with open(os.path.join(directory, run + ".run.json")) as f:
        record = json.load(f)
    points = record["fluid"] + record["walls"]
    datasets = ET.parse(os.path.join(directory, pvd)).getroot().iter("DataSet")
    frames = 0
    for ds in datasets:
        reader = vtkXMLPolyDataReader()
        reader.SetFileName(os.path.join(directory, ds.get("file")))
        reader.Update()
        data = reader.GetOutput()
        assert data.GetNumberOfPoints() == points, (ds.get("file"), data.GetNumberOfPoints(), points)
        assert data.GetNumberOfVerts() == points, ds.get("file")
        pd = data.GetPointData()
        for name, comps in FIELDS.items():
            arr = pd.GetArray(name)
            assert arr is not None, (ds.get("file"), name)
            assert arr.GetNumberOfComponents() == comps, (name, arr.GetNumberOfComponents())
            assert arr.GetNumberOfTuples() == points, name
            assert all(math.isfinite(v) for v in vtk_to_numpy(arr).ravel()), name
        coords = vtk_to_numpy(data.GetPoints().GetData())
        assert coords.shape == (points, 3) and all(math.isfinite(v) for v in coords.ravel())
        frames += 1
    assert frames > 0, pvd
    return run, frames, points


def main():
    directory = sys.argv[1]
    pvds = sorted(p for p in os.listdir(directory) if p.endswith(".pvd"))
    if not pvds:
        sys.exit(f"no .pvd in {directory}")
    for pvd in pvds:
        run, frames, points = check_run(directory, pvd)
        print(f"{run}: {frames} frames of {points} points read by VTK {vtkVersion.GetVTKVersion()}: ok")


if __name__ == "__main__":
    main()
