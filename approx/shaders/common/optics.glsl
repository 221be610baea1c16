// Specular optics shared by the tracer: unpolarised dielectric Fresnel
// reflectance, Snell refraction, mirror reflection.
#ifndef VOLCAUSTICS_OPTICS_GLSL
#define VOLCAUSTICS_OPTICS_GLSL

// Fresnel reflectance of an unpolarised wave at a dielectric interface.
// cos_i: cosine between the incident direction (reversed) and the normal on the
// incident side (> 0); eta = n_transmitted / n_incident. Returns 1 under total
// internal reflection. Fresnel equations as in Born & Wolf §1.5, cosine form.
float fresnel_dielectric(float cos_i, float eta) {
    float sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if (sin2_t >= 1.0) return 1.0;
    float cos_t = sqrt(1.0 - sin2_t);
    float r_s = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    float r_p = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    return 0.5 * (r_s * r_s + r_p * r_p);
}

// Refraction of unit direction d at unit normal n facing the incident side
// (dot(d, n) < 0), eta = n_t / n_i. Returns false under total internal reflection.
bool refract_dir(vec3 d, vec3 n, float eta, out vec3 t) {
    float cos_i = -dot(d, n);
    float sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if (sin2_t >= 1.0) { t = vec3(0.0); return false; }
    float cos_t = sqrt(1.0 - sin2_t);
    t = normalize(d / eta + (cos_i / eta - cos_t) * n);
    return true;
}

vec3 reflect_dir(vec3 d, vec3 n) {
    return d - 2.0 * dot(d, n) * n;
}

#endif
