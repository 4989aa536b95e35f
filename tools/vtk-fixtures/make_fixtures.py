#!/usr/bin/env python3
"""Fixtures for the VTU/VTP reader written by the real writers, not by Meniscus' own (issue #16).

Writes tests/fixtures/vtk/*.vtu|*.vtp with VTK's own XML writers (the `vtk` wheel:
vtkXMLUnstructuredGridWriter / vtkXMLPolyDataWriter) in every data mode (ascii, binary = inline base64,
appended raw, appended base64), header type (UInt32, UInt64), byte order and compressor (none, ZLib, LZ4,
LZMA), a few files written by meshio, and a ParaView `.pvd` time series of three VTU files listed out of
timestep order. Every file holds the same 25 particles (see `data()`), which tests/vtk_fixtures.rs recomputes:
positions (Float64), velocity (3 × Float64), density (Float32), id (Int64).

Run: pip install vtk meshio; python3 tools/vtk-fixtures/make_fixtures.py   (VTK 9.x; the committed files were
made with the versions printed into tests/fixtures/vtk/MANIFEST.txt)
"""
import os
import sys

import numpy as np
import vtk
from vtk.util.numpy_support import numpy_to_vtk

OUT = os.path.join(os.path.dirname(__file__), "..", "..", "tests", "fixtures", "vtk")
N = 25


def data(shift=0.0):
    i = np.arange(N, dtype=np.float64)
    pos = np.stack([0.1 * i + shift, 0.5 + 0.01 * i * i, -0.2 * i + 0.003 * i ** 3], axis=1)
    vel = np.stack([i, -0.5 * i, np.full(N, 0.25)], axis=1)
    rho = (1000.0 + 0.5 * i).astype(np.float32)
    ids = (3 * np.arange(N) + 1).astype(np.int64)
    return pos, vel, rho, ids


def arrays(ds, vel, rho, ids):
    for name, a in [("velocity", vel), ("density", rho), ("id", ids)]:
        v = numpy_to_vtk(a, deep=True)
        v.SetName(name)
        ds.GetPointData().AddArray(v)


def unstructured(shift=0.0):
    pos, vel, rho, ids = data(shift)
    pts = vtk.vtkPoints()
    pts.SetData(numpy_to_vtk(pos, deep=True))
    g = vtk.vtkUnstructuredGrid()
    g.SetPoints(pts)
    for k in range(N):
        g.InsertNextCell(vtk.VTK_VERTEX, 1, [k])
    arrays(g, vel, rho, ids)
    return g


def polydata():
    pos, vel, rho, ids = data()
    pts = vtk.vtkPoints()
    pts.SetData(numpy_to_vtk(pos, deep=True))
    p = vtk.vtkPolyData()
    p.SetPoints(pts)
    verts = vtk.vtkCellArray()
    for k in range(N):
        verts.InsertNextCell(1, [k])
    p.SetVerts(verts)
    arrays(p, vel, rho, ids)
    return p


def write(kind, name, mode, header="UInt64", order="LE", comp=None, b64=True):
    w = vtk.vtkXMLUnstructuredGridWriter() if kind == "vtu" else vtk.vtkXMLPolyDataWriter()
    w.SetInputData(unstructured() if kind == "vtu" else polydata())
    w.SetFileName(os.path.join(OUT, name))
    {"ascii": w.SetDataModeToAscii, "binary": w.SetDataModeToBinary, "appended": w.SetDataModeToAppended}[mode]()
    w.SetEncodeAppendedData(1 if b64 else 0)
    w.SetHeaderTypeToUInt32() if header == "UInt32" else w.SetHeaderTypeToUInt64()
    w.SetByteOrderToBigEndian() if order == "BE" else w.SetByteOrderToLittleEndian()
    if comp is None:
        w.SetCompressorTypeToNone()
    else:
        {"zlib": w.SetCompressorTypeToZLib, "lz4": w.SetCompressorTypeToLZ4, "lzma": w.SetCompressorTypeToLZMA}[comp]()
        w.SetBlockSize(256)  # several blocks per array, the last one partial
    assert w.Write() == 1, name
    return f"{name}: VTK {kind} writer, mode {mode}{'' if mode != 'appended' else (' base64' if b64 else ' raw')}, header {header}, {order}, compressor {comp or 'none'}"


def main():
    os.makedirs(OUT, exist_ok=True)
    lines = [f"VTK {vtk.vtkVersion.GetVTKVersion()}, python {sys.version.split()[0]}"]
    for kind in ["vtu", "vtp"]:
        lines.append(write(kind, f"{kind}_ascii.{kind}", "ascii"))
        for mode, b64 in [("binary", True), ("appended", True), ("appended", False)]:
            tag = mode if mode == "binary" else ("appended_b64" if b64 else "appended_raw")
            for comp in [None, "zlib", "lz4", "lzma"]:
                for header in ["UInt32", "UInt64"]:
                    name = f"{kind}_{tag}_{comp or 'none'}_{header.lower()}.{kind}"
                    lines.append(write(kind, name, mode, header=header, comp=comp, b64=b64))
            for comp in [None, "zlib"]:
                name = f"{kind}_{tag}_{comp or 'none'}_be.{kind}"
                lines.append(write(kind, name, mode, header="UInt32", order="BE", comp=comp, b64=b64))
    # meshio (its own VTU writer; vertex cells).
    import meshio
    pos, vel, rho, ids = data()
    mesh = meshio.Mesh(pos, [("vertex", np.arange(N).reshape(-1, 1))],
                       point_data={"velocity": vel, "density": rho, "id": ids})
    for binary, comp in [(False, None), (True, None), (True, "zlib"), (True, "lzma")]:
        name = f"meshio_{'binary' if binary else 'ascii'}_{comp or 'none'}.vtu"
        meshio.write(os.path.join(OUT, name), mesh, binary=binary, compression=comp)
        lines.append(f"{name}: meshio {meshio.__version__}, binary {binary}, compression {comp}")
    # A ParaView time series: three VTU files, listed out of timestep order; particles shifted by t in x.
    os.makedirs(os.path.join(OUT, "series"), exist_ok=True)
    entries = []
    for k, t in enumerate([0.0, 0.5, 1.0]):
        w = vtk.vtkXMLUnstructuredGridWriter()
        w.SetInputData(unstructured(shift=t))
        w.SetFileName(os.path.join(OUT, "series", f"step_{k}.vtu"))
        w.SetDataModeToAppended()
        assert w.Write() == 1
        entries.append((t, f"series/step_{k}.vtu"))
    with open(os.path.join(OUT, "series.pvd"), "w") as f:
        f.write('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">\n  <Collection>\n')
        for t, path in [entries[2], entries[0], entries[1]]:
            f.write(f'    <DataSet timestep="{t}" group="" part="0" file="{path}"/>\n')
        f.write("  </Collection>\n</VTKFile>\n")
    lines.append("series.pvd: three appended VTU files (x shifted by the timestep 0, 0.5, 1), listed as 1, 0, 0.5")
    with open(os.path.join(OUT, "MANIFEST.txt"), "w") as f:
        f.write("\n".join(lines) + "\n")
    print(f"{len(lines) - 1} fixtures in {os.path.normpath(OUT)}")


if __name__ == "__main__":
    main()
