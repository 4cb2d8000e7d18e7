"""VTK frames in Python: read the ``.vtp`` files fissure writes with meshio.

``World.save_vtk(path)`` (and ``fissure run --mesh vtk``) writes VTK XML PolyData (``.vtp``): points, triangles,
point data ``velocity``, ``strain``, ``body`` and cell data ``body``, ``damage``. ParaView, VisIt and PyVista
read it. meshio (5.3) reads VTK XML UnstructuredGrid (``.vtu``) but has no PolyData reader, so this module gives
it one: :func:`read_vtp` turns the PolyData tree into the equivalent UnstructuredGrid (the same arrays; ``Polys``
become ``Cells`` with their VTK cell types) and hands it to meshio's own VTU reader, and :func:`register_meshio`
makes ``meshio.read("frame.vtp")`` use it.

    import meshio, fissure.vtk
    fissure.vtk.register_meshio()
    mesh = meshio.read("target/fissure-run/fracture/run_0010.vtp")
    mesh.points, mesh.cells_dict["triangle"], mesh.point_data["strain"], mesh.cell_data["damage"]

meshio is optional: ``pip install fissure[vtk]``.
"""

from __future__ import annotations

import os
import tempfile
import xml.etree.ElementTree as ET
from typing import Any

__all__ = ["read_vtp", "register_meshio"]

# VTK cell types by corner count: triangle, quad, polygon.
_TRIANGLE, _QUAD, _POLYGON = 5, 9, 7


def read_vtp(path: str | os.PathLike[str]) -> Any:
    """A ``.vtp`` file (VTK XML PolyData of polygons, ASCII) as a ``meshio.Mesh``."""
    import meshio

    root = ET.parse(os.fspath(path)).getroot()
    if root.tag != "VTKFile" or root.get("type") != "PolyData":
        raise meshio.ReadError(f"{os.fspath(path)}: not a VTK XML PolyData file")
    root.set("type", "UnstructuredGrid")
    grid = root.find("PolyData")
    if grid is None:
        raise meshio.ReadError(f"{os.fspath(path)}: no PolyData element")
    grid.tag = "UnstructuredGrid"
    for piece in grid.findall("Piece"):
        for other in ("NumberOfVerts", "NumberOfLines", "NumberOfStrips"):
            if int(piece.get(other, "0")) != 0:
                raise meshio.ReadError(f"{os.fspath(path)}: {other} > 0 (only polygons are read)")
        polys = piece.find("Polys")
        count = int(piece.get("NumberOfPolys", "0"))
        piece.attrib = {"NumberOfPoints": piece.get("NumberOfPoints", "0"), "NumberOfCells": str(count)}
        if polys is None:
            polys = ET.SubElement(piece, "Polys")
        polys.tag = "Cells"
        offsets = polys.find("DataArray[@Name='offsets']")
        if offsets is None or offsets.get("format") != "ascii":
            raise meshio.ReadError(f"{os.fspath(path)}: want ASCII offsets (as fissure writes)")
        ends = [int(x) for x in (offsets.text or "").split()]
        sizes = [b - a for a, b in zip([0] + ends[:-1], ends)]
        types = ET.SubElement(polys, "DataArray", type="UInt8", Name="types", format="ascii")
        types.text = " ".join(str({3: _TRIANGLE, 4: _QUAD}.get(n, _POLYGON)) for n in sizes)
    with tempfile.TemporaryDirectory(prefix="fissure-vtp-") as tmp:
        vtu = os.path.join(tmp, "frame.vtu")
        ET.ElementTree(root).write(vtu, xml_declaration=True, encoding="utf-8")
        return meshio.vtu.read(vtu)


def register_meshio() -> None:
    """Makes ``meshio.read`` read ``.vtp`` files through :func:`read_vtp`."""
    import meshio

    meshio.register_format("vtp", [".vtp"], read_vtp, {})
