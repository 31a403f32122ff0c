/* The viewer's renderer (OpenGL 3.3 core): one set of GPU buffers per
 * primitive, written by the ranges the C API says changed
 * (ms_session_mesh_changes), grown by a GPU-side copy, drawn once per
 * instance with a head light, predicted vertices tinted on request.
 * docs/engine-integration.md, "Buffers by range", explains the pattern.
 *
 * Shared by examples/viewer/main.c and the test's reference renderer
 * (tests/viewer/render_reference.cc), so that a streamed frame and a frame of
 * the exported file are drawn by the same code. Needs a current GL 3.3 core
 * context; not thread safe (GL's rules). */
#ifndef MESHSTREAM_EXAMPLES_VIEWER_RENDER_H_
#define MESHSTREAM_EXAMPLES_VIEWER_RENDER_H_

#include <stddef.h>
#include <stdint.h>

#define GL_GLEXT_PROTOTYPES 1
#include <GL/glcorearb.h>

#include "meshstream/meshstream.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct {
  GLuint program;
  GLint u_view_projection, u_model, u_has_normals, u_tint;
  uint64_t bytes_uploaded;   /* written by glBufferSubData or a flushed mapping */
  uint64_t bytes_copied;     /* moved on the GPU when a buffer grew */
  uint64_t upload_calls;     /* glBufferSubData calls and flushed ranges */
} vw_renderer;

typedef struct {
  GLuint vao, positions, normals, predicted, indices;
  uint32_t vertex_capacity, index_capacity; /* in vertices, indices */
  uint32_t vertex_count, index_count;       /* what is drawn */
  int has_normals;
  float* instances;                         /* 16 floats each, owned */
  uint32_t instance_count;
} vw_primitive;

/* Compiles the shaders; 0 on success, else -1 with the message in *error. */
int vw_renderer_init(vw_renderer* r, const char** error);
void vw_renderer_free(vw_renderer* r);

void vw_primitive_init(vw_primitive* p);
void vw_primitive_free(vw_primitive* p);
/* Copies the instance matrices (count * 16 floats). */
void vw_primitive_set_instances(vw_primitive* p, const float* matrices, uint32_t count);

/* Brings the primitive's buffers to a view of vertex_count vertices and
 * index_count indices by writing only the given ranges of each array
 * (normals may be NULL: then none are drawn; predicted may be NULL: all 0).
 * Vertex ranges first, then index ranges; the draw counts change last. A
 * buffer too small grows by 3/2 (at least to what is needed) with its valid
 * part copied on the GPU. */
void vw_primitive_update(vw_renderer* r, vw_primitive* p, uint32_t vertex_count, const float* positions,
                         const float* normals, const uint8_t* predicted, const ms_range* vertex_ranges,
                         uint32_t vertex_range_count, uint32_t index_count, const uint32_t* indices,
                         const ms_range* index_ranges, uint32_t index_range_count);

/* Reads the primitive's buffers back and compares them with the arrays;
 * returns the number of arrays that differ (0: the GPU holds the view). */
int vw_primitive_verify(const vw_primitive* p, const float* positions, const float* normals,
                        const uint8_t* predicted, const uint32_t* indices);

/* Clears and draws every primitive at every instance. */
void vw_draw(const vw_renderer* r, const vw_primitive* primitives, uint32_t count, const float view_projection[16],
             int tint_predicted, int width, int height);

/* The bound framebuffer as RGB rows from the top (width * height * 3 bytes). */
void vw_read_pixels(int width, int height, uint8_t* rgb);
/* Writes a binary PPM; 0 on success. */
int vw_write_ppm(const char* path, int width, int height, const uint8_t* rgb);
/* The background's colour (what vw_draw clears to). */
extern const uint8_t vw_background[3];

/* Column-major 4x4 helpers. */
void vw_perspective(float fov_y_degrees, float aspect, float near_plane, float far_plane, float out[16]);
void vw_look_at(const float eye[3], const float target[3], const float up[3], float out[16]);
void vw_multiply(const float a[16], const float b[16], float out[16]);

#ifdef __cplusplus
}
#endif

#endif /* MESHSTREAM_EXAMPLES_VIEWER_RENDER_H_ */
