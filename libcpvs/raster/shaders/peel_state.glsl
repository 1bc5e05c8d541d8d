#version 330 core
// Count values of finished texels: > -500 normal (exit found or never active), kCapped, kStuck.
const float kCapped = -1000.0;   // still inside at the peel cap: exit = last consumed event
const float kStuck = -2000.0;    // inside, no closed back face left before the far plane: exit = N
