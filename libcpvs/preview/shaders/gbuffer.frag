// Position (w = 1 where covered; the clear value 0 marks the background), the normal of the side the camera
// sees (an open surface seen from behind shows its back), base colour.
in vec3 vPosition;
flat in vec3 vNormal;
flat in vec4 vColor;
layout(location = 0) out vec4 outPosition;
layout(location = 1) out vec4 outNormal;
layout(location = 2) out vec4 outColor;
void main() {
  outPosition = vec4(vPosition, 1.0);
  outNormal = vec4(gl_FrontFacing ? vNormal : -vNormal, 0.0);
  outColor = vColor;
}
