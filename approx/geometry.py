"""Scene meshes uploaded once per scene: vertex buffers for the light and camera passes.

Only what the meshes alone determine lives here. The medium's box
(``scenes.bounds.medium_bounds``) also holds the light and the camera, which may
move between frames, so the renderer computes it per frame from the scene it renders.
"""

from __future__ import annotations

from dataclasses import dataclass

import moderngl
import numpy as np

from .glsl import attribute_layout

VERTEX_FORMAT = "3f 3f 3f 1f"  # position, smooth normal, face normal, material index
VERTEX_ATTRIBUTES = ("in_position", "in_normal", "in_face_normal", "in_material")
VERTEX_FLOATS = 10


def interleave(mesh, material: int) -> np.ndarray:
    """(3·F)×10 float32 un-indexed triangles: position, angle-weighted vertex normal
    (shading), the triangle's geometric normal (outward; the inside/outside rule of
    DESIGN.md needs it at every hit), material."""
    normals = mesh.vertex_normals()
    idx = mesh.faces.reshape(-1)
    data = np.empty((len(idx), VERTEX_FLOATS), dtype=np.float32)
    data[:, :3] = mesh.vertices[idx]
    data[:, 3:6] = normals[idx]
    data[:, 6:9] = np.repeat(mesh.face_normals(), 3, axis=0)
    data[:, 9] = material
    return data


@dataclass
class SceneGeometry:
    """GPU buffers of one scene's meshes and the specular objects' bounds."""

    specular: moderngl.Buffer
    diffuse: moderngl.Buffer | None
    specular_vertices: int
    diffuse_ranges: list  # (first vertex, count) per diffuse surface
    specular_min: np.ndarray
    specular_max: np.ndarray

    @classmethod
    def upload(cls, ctx: moderngl.Context, scene) -> "SceneGeometry":
        spec = [interleave(o.mesh.load(), i) for i, o in enumerate(scene.specular)]
        diff = [interleave(o.mesh.load(), i) for i, o in enumerate(scene.diffuse)]
        spec_data = np.concatenate(spec) if spec else np.zeros((0, VERTEX_FLOATS), np.float32)
        ranges, first = [], 0
        for d in diff:
            ranges.append((first, len(d)))
            first += len(d)
        spec_min = spec_data[:, :3].min(0) if len(spec_data) else np.zeros(3)
        spec_max = spec_data[:, :3].max(0) if len(spec_data) else np.zeros(3)
        return cls(
            specular=ctx.buffer(spec_data.tobytes() if len(spec_data)
                                else np.zeros(VERTEX_FLOATS, np.float32).tobytes()),
            diffuse=ctx.buffer(np.concatenate(diff).tobytes()) if diff else None,
            specular_vertices=len(spec_data),
            diffuse_ranges=ranges,
            specular_min=spec_min.astype(np.float64), specular_max=spec_max.astype(np.float64),
        )

    def vertex_array(self, ctx, program, which: str) -> moderngl.VertexArray | None:
        buf = self.specular if which == "specular" else self.diffuse
        if buf is None or (which == "specular" and self.specular_vertices == 0):
            return None
        fmt, names = attribute_layout(program, list(zip(VERTEX_FORMAT.split(), VERTEX_ATTRIBUTES)))
        return ctx.vertex_array(program, [(buf, fmt, *names)])

    def release(self):
        self.specular.release()
        if self.diffuse is not None:
            self.diffuse.release()
