"""Scene meshes uploaded once per scene: vertex buffers for the light and camera passes.

The meshes lie in the buffers in *object* space; each frame writes every object's
object-to-world matrix (``scenes.model.Transform``) into one uniform block
(``shaders/common/model.glsl``) that every pass's vertex shader applies, so rigid
objects move between frames without a re-upload (docs/over-time.md, and a
renderer built on the moved scene computes the very same floats. What depends on
where the objects are — the specular objects' box, the medium's box
(``scenes.bounds.medium_bounds``, which also holds the light and the camera) — is
computed per frame from the scene being rendered.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import moderngl
import numpy as np

from volcaustics.scenes.model import Transform

from .glsl import attribute_layout, uniform

if TYPE_CHECKING:
    from volcaustics.scenes.mesh import Mesh
    from volcaustics.scenes.model import DiffuseSurface, MeshSpec, Scene, SpecularObject

VERTEX_FORMAT = "3f 3f 3f 1f"  # position, smooth normal, face normal, material index
VERTEX_ATTRIBUTES = ("in_position", "in_normal", "in_face_normal", "in_material")
VERTEX_FLOATS = 10
MAX_MODELS = 256  # objects (specular + diffuse): 256 mat4 fill the 16 KiB every GL 4.3 uniform block may hold
MODELS_BINDING = 0  # the uniform block binding of shaders/common/model.glsl


def object_space(spec: SpecularObject | DiffuseSurface) -> MeshSpec:
    """The mesh spec without its placement: what the vertex buffers hold."""
    return replace(spec.mesh, transform=Transform())


def model_matrices(scene: Scene) -> np.ndarray:
    """MAX_MODELS×4×4 float32 object-to-world matrices, column-major per matrix (std140
    ``mat4``): specular objects first, then diffuse surfaces, then identity padding."""
    objects: tuple[SpecularObject | DiffuseSurface, ...] = (*scene.specular, *scene.diffuse)
    if len(objects) > MAX_MODELS:
        raise ValueError(f"at most {MAX_MODELS} objects (specular + diffuse) are supported, scene has {len(objects)}")
    models = np.tile(np.eye(4, dtype=np.float32), (MAX_MODELS, 1, 1))
    for i, obj in enumerate(objects):
        models[i] = obj.mesh.transform.matrix().T  # transposed: numpy row-major bytes = GLSL column-major
    return models


def bind_identity_models(ctx: moderngl.Context, program: moderngl.Program) -> moderngl.Buffer:
    """For a draw of world-space vertices through the shared vertex stage (the preview):
    identity matrices bound, model_base 0; returns the buffer (the caller releases it)."""
    models = ctx.buffer(np.tile(np.eye(4, dtype=np.float32), (MAX_MODELS, 1, 1)).tobytes())
    models.bind_to_uniform_block(MODELS_BINDING)
    uniform(program, "model_base").value = 0
    return models


def specular_bounds(scene: Scene) -> tuple[np.ndarray, np.ndarray]:
    """(min, max) of the specular objects' world vertices (float32-rounded, as the GPU holds
    them up to its own rounding: users pad), each (3,) float64; zeros without objects."""
    if not scene.specular:
        return np.zeros(3), np.zeros(3)
    points = np.concatenate([o.mesh.load().vertices for o in scene.specular]).astype(np.float32)
    return points.min(0).astype(np.float64), points.max(0).astype(np.float64)


def interleave(mesh: Mesh, material: int) -> np.ndarray:
    """(3·F)×10 float32 un-indexed triangles: position, angle-weighted vertex normal
    (shading), the triangle's geometric normal (outward; the inside/outside rule of
    docs/conventions.md needs it at every hit), material."""
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
    """GPU buffers of one scene's meshes (object space) and its objects' matrices."""

    specular: moderngl.Buffer
    diffuse: moderngl.Buffer | None
    specular_vertices: int
    diffuse_ranges: list  # (first vertex, count) per diffuse surface
    models: moderngl.Buffer  # uniform block: MAX_MODELS object-to-world matrices (model_matrices)
    meshes: tuple  # object-space mesh spec per object (specular, then diffuse): what may not change
    objects_box: tuple  # the placed specular objects' bounds (specular_bounds)

    @classmethod
    def upload(cls, ctx: moderngl.Context, scene: Scene) -> "SceneGeometry":
        objects: tuple[SpecularObject | DiffuseSurface, ...] = (*scene.specular, *scene.diffuse)
        meshes = tuple(object_space(o) for o in objects)
        spec = [interleave(m.load(), i) for i, m in enumerate(meshes[:len(scene.specular)])]
        diff = [interleave(m.load(), i) for i, m in enumerate(meshes[len(scene.specular):])]
        spec_data = np.concatenate(spec) if spec else np.zeros((0, VERTEX_FLOATS), np.float32)
        ranges, first = [], 0
        for d in diff:
            ranges.append((first, len(d)))
            first += len(d)
        return cls(
            specular=ctx.buffer(spec_data.tobytes() if len(spec_data)
                                else np.zeros(VERTEX_FLOATS, np.float32).tobytes()),
            diffuse=ctx.buffer(np.concatenate(diff).tobytes()) if diff else None,
            specular_vertices=len(spec_data),
            diffuse_ranges=ranges,
            models=ctx.buffer(model_matrices(scene).tobytes()),
            meshes=meshes,
            objects_box=specular_bounds(scene),
        )

    def place(self, scene: Scene) -> None:
        """Put every object where ``scene`` has it (its transforms) for the next passes;
        ``scene`` must hold the uploaded meshes, in the same order."""
        objects: tuple[SpecularObject | DiffuseSurface, ...] = (*scene.specular, *scene.diffuse)
        meshes = tuple(object_space(o) for o in objects)
        if meshes != self.meshes:
            raise ValueError(f"{scene.name}: its meshes differ from the ones this renderer uploaded (objects may move, "
                             "rotate and scale between frames, not change shape or number): use a new Renderer")
        self.models.write(model_matrices(scene).tobytes())
        self.objects_box = specular_bounds(scene)

    def use(self, program: moderngl.Program, which: str) -> None:
        """Before drawing ``which`` ("specular" or "diffuse") with ``program``: this scene's
        matrices in the uniform block (a binding is context state that other renderers
        on the shared context change) and the index of ``which``'s first matrix."""
        self.models.bind_to_uniform_block(MODELS_BINDING)
        uniform(program, "model_base").value = 0 if which == "specular" else len(self.meshes) - len(self.diffuse_ranges)

    def vertex_content(self, program: moderngl.Program, which: str) -> list | None:
        """The vertex array content (moderngl's) of ``which`` ("specular" or "diffuse")
        for ``program``; None where the scene has none."""
        buf = self.specular if which == "specular" else self.diffuse
        if buf is None or (which == "specular" and self.specular_vertices == 0):
            return None
        fmt, names = attribute_layout(program, list(zip(VERTEX_FORMAT.split(), VERTEX_ATTRIBUTES)))
        return [(buf, fmt, *names)]

    def vertex_array(self, ctx: moderngl.Context, program: moderngl.Program, which: str) -> moderngl.VertexArray | None:
        content = self.vertex_content(program, which)
        return None if content is None else ctx.vertex_array(program, content)

    def release(self) -> None:
        self.models.release()
        self.specular.release()
        if self.diffuse is not None:
            self.diffuse.release()
