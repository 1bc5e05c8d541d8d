// The records cpvs-view uploads for the GPU lookups (libcpvs/runtime/gpu_records.cpp writes them; lookup_cell.glsl,
// the culling and the shading read them): per view CPVS_MAP_REALS doubles (ViewMapping's constants) and
// CPVS_VIEW_WORDS uints (flags and where its DAG lies), per light CPVS_LIGHT_REALS doubles and CPVS_LIGHT_WORDS
// uints. Plain arrays of doubles and uints, so std430's struct rules never come in.
#define CPVS_MAP_ROW 0u        // 12 values: row[i][j] at 4 i + j
#define CPVS_MAP_XMIN 12u
#define CPVS_MAP_YMIN 13u
#define CPVS_MAP_USCALE 14u
#define CPVS_MAP_VSCALE 15u
#define CPVS_MAP_USTEP 16u
#define CPVS_MAP_VSTEP 17u
#define CPVS_MAP_NEAR 18u
#define CPVS_MAP_INVNEAR 19u
#define CPVS_MAP_SSCALE 20u
#define CPVS_MAP_INVDS 21u
#define CPVS_MAP_RESOLUTION 22u
#define CPVS_MAP_REALS 24u     // per view (padded)

#define CPVS_FLAG_ORTHOGRAPHIC 1u
#define CPVS_FLAG_LINEAR 2u
#define CPVS_FLAG_EMPTY 4u

#define CPVS_LIGHT_POSITION 0u  // 3 values
#define CPVS_LIGHT_DIRECTION 3u // 3 values, the way the light travels
#define CPVS_LIGHT_RANGE 6u     // +inf: unbounded
#define CPVS_LIGHT_COS_OUTER 7u // cos(min(outer cone, pi / 2)), as spotInfluence computes it
#define CPVS_LIGHT_SIN_OUTER 8u // sin of the same angle (tile culling)
#define CPVS_LIGHT_COS_INNER 9u // cos(inner cone) (shading's smooth cone)
#define CPVS_LIGHT_COLOR 10u    // 3 values, linear RGB
#define CPVS_LIGHT_INTENSITY 13u
#define CPVS_LIGHT_REALS 16u    // per light

#define CPVS_LIGHT_TYPE 0u       // CPVS_LIGHT_DIRECTIONAL, _SPOT, _POINT (light.glsl.h)
#define CPVS_LIGHT_FIRST_VIEW 1u // the light's first view in the view records
#define CPVS_LIGHT_VIEW_COUNT 2u
#define CPVS_LIGHT_DISABLED 3u    // 1: switched off in the viewer (left out of every tile's list)
#define CPVS_LIGHT_SHADOW_LIGHT 10u // the light record whose views hold this light's shadow maps (cpvs-view's
                                 // shadow-map modes: itself, or its LightCluster cluster)
#define CPVS_LIGHT_FACE_VIEW 4u  // 6 values: a point light's view (relative to the first) per cube face, ~0u: none
#define CPVS_LIGHT_SHAPE 11u     // CPVS_SHAPE_* bits (light.glsl.h): what the shaders branch on
#define CPVS_LIGHT_WORDS 12u     // per light

#define CPVS_VIEW_FLAGS 0u       // CPVS_FLAG_*
#define CPVS_VIEW_NODE_BASE 1u   // the u16 unit of the view's root in the shared node buffer (a 3.x view's
                                 // lies inside its file's pool, which the buffer holds once)
#define CPVS_VIEW_LEAF_BASE 2u   // first leaf of the view's leaves in the shared leaf buffer
#define CPVS_VIEW_ROOT_CODE 3u
#define CPVS_VIEW_RESOLUTION 4u
#define CPVS_VIEW_LAYER 5u       // cpvs-view's shadow-map modes: the view's layer in the map array
#define CPVS_VIEW_ATLAS_X 6u     // and its texel origin in that layer (ManyPSMs' atlas; 0 for a map per layer)
#define CPVS_VIEW_ATLAS_Y 7u
#define CPVS_VIEW_CHILD_BASE 8u  // 32 values: DagView::childBase
#define CPVS_VIEW_WORDS 40u      // per view

