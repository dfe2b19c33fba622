#version 330 core
// Demo vertex shader for a Lambertian mesh lit by SH9 (pairs with lit_diffuse.frag).
// Frame: world space, right-handed, +Y up (the frame of the wire matrices).
uniform mat4 model;            // object -> world
uniform mat4 viewProjection;   // world -> clip
uniform mat3 normalMatrix;     // inverse transpose of model's upper 3x3

in vec3 in_position;
in vec3 in_normal;

out vec3 worldNormal;

void main() {
    worldNormal = normalMatrix * in_normal;
    gl_Position = viewProjection * (model * vec4(in_position, 1.0));
}
