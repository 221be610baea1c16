// One image added into the target (additive blending, approx.camera_pass.CameraPasses.compose):
// the frame's layers summed on the GPU in the order the host sums them (step images, then
// caustic + fog + direct), texel for texel, so the composed image equals the host's sum.
uniform sampler2D image;
out vec4 color;

void main() {
    color = texelFetch(image, ivec2(gl_FragCoord.xy), 0);
}
