// The scene box where the medium is (scenes/bounds.py; numpy twin: scenes.bounds.box_exit).
#ifndef VOLCAUSTICS_BOX_GLSL
#define VOLCAUSTICS_BOX_GLSL

// Distance along d from o (inside the box [box_min, box_max]) to the exit of the box.
float box_exit(vec3 o, vec3 d, vec3 box_min, vec3 box_max) {
    vec3 inv = 1.0 / d;
    vec3 t_far = max((box_min - o) * inv, (box_max - o) * inv);
    return max(min(min(t_far.x, t_far.y), t_far.z), 0.0);
}

#endif
