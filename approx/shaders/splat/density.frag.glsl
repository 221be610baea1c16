// splat = density, the pre-pass: one photon, added into its cell.
out vec4 out_count;

void main() { out_count = vec4(1.0, 0.0, 0.0, 0.0); }
