// Rigid object motion (docs/over-time.md: meshes are uploaded once, in
// object space; each object's object-to-world matrix (uniform scale, so mat3(m)
// carries normals up to length) is read from this block by the vertex's material
// index plus the draw's model_base (specular objects first, then diffuse surfaces).
#ifndef MAX_MODELS
#define MAX_MODELS 256
#endif
layout(std140, binding = 0) uniform Models { mat4 models[MAX_MODELS]; };
uniform int model_base;

mat4 object_to_world(float material) {
    return models[model_base + int(material)];
}
