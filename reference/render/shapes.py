"""What each Mitsuba shape of an exported scene is, for vectorised lookups.

Shapes are told apart by their registry id (``dr.reinterpret_array(UInt32,
ShapePtr)``, a small integer): tables indexed by it give the kind, the object
index in our scene model and the glass absorption coefficient.
"""

from __future__ import annotations

from types import ModuleType
from typing import Any

from volcaustics.scenes.formats import KIND_BOUNDARY, KIND_DIFFUSE, KIND_NONE, KIND_SPECULAR


class ShapeTable:
    """kind (UInt32, ``scenes.formats`` KIND_*), index (Int32) and absorption (Color3f) by shape registry id."""

    def __init__(self, mi, mi_scene, scene):
        import drjit as dr

        entries = {}
        for shape in mi_scene.shapes():
            sid = int(dr.reinterpret_array(mi.UInt32, mi.ShapePtr(shape))[0])
            name = shape.id()
            if name.startswith("specular_"):
                i = int(name.split("_")[1])
                entries[sid] = (KIND_SPECULAR, i, scene.specular[i].absorption)
            elif name.startswith("diffuse_"):
                i = int(name.split("_")[1])
                entries[sid] = (KIND_DIFFUSE, i, (0.0, 0.0, 0.0))
            elif name == "medium_box":
                entries[sid] = (KIND_BOUNDARY, -1, (0.0, 0.0, 0.0))
        if any(not shape.id() for shape in mi_scene.shapes()):  # Mitsuba's merged shapes have no id
            raise RuntimeError(f"the Mitsuba scene lost or renamed objects ({[s.id() for s in mi_scene.shapes()]}): "
                               f"load it with export.load_scene (no merging)")
        size = max(entries, default=0) + 1
        kind, index, absorption = [KIND_NONE] * size, [-1] * size, [(0.0, 0.0, 0.0)] * size
        for sid, (k, i, a) in entries.items():
            kind[sid], index[sid], absorption[sid] = k, i, a
        self.kind = mi.UInt32(kind)
        self.index = mi.Int32(index)
        self.absorption = mi.Color3f([a[0] for a in absorption], [a[1] for a in absorption],
                                     [a[2] for a in absorption])
        self.entries = entries

    def lookup(self, mi: ModuleType, si: Any, active: Any) -> tuple[Any, Any, Any]:
        """(kind, index, absorption) of the shapes hit by ``si`` (KIND_NONE on a miss)."""
        import drjit as dr

        sid: Any = dr.reinterpret_array(mi.UInt32, si.shape)  # Dr.Jit's stubs say object
        ok = active & si.is_valid()
        return (dr.gather(mi.UInt32, self.kind, sid, ok), dr.gather(mi.Int32, self.index, sid, ok, ),
                dr.gather(mi.Color3f, self.absorption, sid, ok))
