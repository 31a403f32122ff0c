/* The viewer's renderer (render.h). */
#include "render.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const uint8_t vw_background[3] = {30, 32, 38};

static const char* kVertexShader =
    "#version 330 core\n"
    "layout(location = 0) in vec3 position;\n"
    "layout(location = 1) in vec3 normal;\n"
    "layout(location = 2) in float predicted;\n"
    "uniform mat4 view_projection;\n"
    "uniform mat4 model;\n"
    "out vec3 world_position;\n"
    "out vec3 world_normal;\n"
    "out float is_predicted;\n"
    "void main() {\n"
    "  vec4 w = model * vec4(position, 1.0);\n"
    "  world_position = w.xyz;\n"
    "  world_normal = transpose(inverse(mat3(model))) * normal;\n"
    "  is_predicted = predicted;\n"
    "  gl_Position = view_projection * w;\n"
    "}\n";

/* Without normals, the face normal from the screen-space derivatives. */
static const char* kFragmentShader =
    "#version 330 core\n"
    "in vec3 world_position;\n"
    "in vec3 world_normal;\n"
    "in float is_predicted;\n"
    "uniform int has_normals;\n"
    "uniform int tint;\n"
    "out vec4 colour;\n"
    "void main() {\n"
    "  vec3 n = has_normals != 0 ? world_normal : cross(dFdx(world_position), dFdy(world_position));\n"
    "  n = length(n) > 0.0 ? normalize(n) : vec3(0.0, 0.0, 1.0);\n"
    "  vec3 light = normalize(vec3(0.4, 0.7, 0.6));\n"
    "  float d = abs(dot(n, light));\n"
    "  vec3 base = vec3(0.78, 0.80, 0.84);\n"
    "  if (tint != 0 && is_predicted > 0.5) base = vec3(1.0, 0.45, 0.1);\n"
    "  colour = vec4(base * (0.25 + 0.75 * d), 1.0);\n"
    "}\n";

static GLuint Compile(GLenum type, const char* source, const char** error) {
  static char log[1024];
  GLuint s = glCreateShader(type);
  glShaderSource(s, 1, &source, NULL);
  glCompileShader(s);
  GLint ok = 0;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    glGetShaderInfoLog(s, sizeof log, NULL, log);
    *error = log;
    glDeleteShader(s);
    return 0;
  }
  return s;
}

int vw_renderer_init(vw_renderer* r, const char** error) {
  static char log[1024];
  memset(r, 0, sizeof *r);
  GLuint vs = Compile(GL_VERTEX_SHADER, kVertexShader, error);
  if (vs == 0) return -1;
  GLuint fs = Compile(GL_FRAGMENT_SHADER, kFragmentShader, error);
  if (fs == 0) return -1;
  r->program = glCreateProgram();
  glAttachShader(r->program, vs);
  glAttachShader(r->program, fs);
  glLinkProgram(r->program);
  glDeleteShader(vs);
  glDeleteShader(fs);
  GLint ok = 0;
  glGetProgramiv(r->program, GL_LINK_STATUS, &ok);
  if (!ok) {
    glGetProgramInfoLog(r->program, sizeof log, NULL, log);
    *error = log;
    return -1;
  }
  r->u_view_projection = glGetUniformLocation(r->program, "view_projection");
  r->u_model = glGetUniformLocation(r->program, "model");
  r->u_has_normals = glGetUniformLocation(r->program, "has_normals");
  r->u_tint = glGetUniformLocation(r->program, "tint");
  return 0;
}

void vw_renderer_free(vw_renderer* r) {
  if (r->program != 0) glDeleteProgram(r->program);
  r->program = 0;
}

void vw_primitive_init(vw_primitive* p) {
  memset(p, 0, sizeof *p);
  glGenVertexArrays(1, &p->vao);
}

void vw_primitive_free(vw_primitive* p) {
  GLuint buffers[4] = {p->positions, p->normals, p->predicted, p->indices};
  for (int i = 0; i < 4; ++i)
    if (buffers[i] != 0) glDeleteBuffers(1, &buffers[i]);
  if (p->vao != 0) glDeleteVertexArrays(1, &p->vao);
  free(p->instances);
  memset(p, 0, sizeof *p);
}

void vw_primitive_set_instances(vw_primitive* p, const float* matrices, uint32_t count) {
  free(p->instances);
  p->instances = NULL;
  p->instance_count = 0;
  if (count == 0) return;
  p->instances = (float*)malloc(sizeof(float) * 16 * count);
  if (p->instances == NULL) return;
  memcpy(p->instances, matrices, sizeof(float) * 16 * count);
  p->instance_count = count;
}

/* A buffer of `capacity` elements of `stride` bytes whose first `valid`
 * elements are those of *buffer (copied on the GPU), replacing it. */
static void Grow(vw_renderer* r, GLenum target, GLuint* buffer, size_t stride, uint32_t valid, uint32_t capacity) {
  GLuint grown = 0;
  glGenBuffers(1, &grown);
  glBindBuffer(GL_COPY_WRITE_BUFFER, grown);
  glBufferData(GL_COPY_WRITE_BUFFER, (GLsizeiptr)(stride * capacity), NULL, GL_DYNAMIC_DRAW);
  if (*buffer != 0 && valid > 0) {
    glBindBuffer(GL_COPY_READ_BUFFER, *buffer);
    glCopyBufferSubData(GL_COPY_READ_BUFFER, GL_COPY_WRITE_BUFFER, 0, 0, (GLsizeiptr)(stride * valid));
    r->bytes_copied += stride * valid;
  }
  if (*buffer != 0) glDeleteBuffers(1, buffer);
  *buffer = grown;
  (void)target;
}

static uint32_t NewCapacity(uint32_t have, uint32_t need) {
  uint64_t c = (uint64_t)have * 3 / 2;
  if (c < need) c = need;
  if (c < 256) c = 256;
  return c > 0xffffffffu ? 0xffffffffu : (uint32_t)c;
}

/* One glBufferSubData per range into the buffer bound to `target`. */
static void SubDataRanges(vw_renderer* r, GLenum target, const uint8_t* bytes, size_t stride, const ms_range* ranges,
                          uint32_t count) {
  for (uint32_t i = 0; i < count; ++i) {
    const size_t offset = stride * ranges[i].first, size = stride * ranges[i].count;
    glBufferSubData(target, (GLintptr)offset, (GLsizeiptr)size, bytes + offset);
    r->bytes_uploaded += size;
    r->upload_calls += 1;
  }
}

/* Writes the ranges of `data` (elements of `stride` bytes) into the buffer
 * bound to `target`: one glBufferSubData per range when they are few, else
 * one mapping of their span with each range flushed explicitly. */
static void WriteRanges(vw_renderer* r, GLenum target, const void* data, size_t stride, const ms_range* ranges,
                        uint32_t count) {
  if (count == 0 || data == NULL) return;
  const uint8_t* bytes = (const uint8_t*)data;
  uint8_t* mapped = NULL;
  const size_t begin = stride * ranges[0].first;
  if (count > 16) {
    const size_t end = stride * ((size_t)ranges[count - 1].first + ranges[count - 1].count);
    mapped = (uint8_t*)glMapBufferRange(target, (GLintptr)begin, (GLsizeiptr)(end - begin),
                                        GL_MAP_WRITE_BIT | GL_MAP_FLUSH_EXPLICIT_BIT);
  }
  if (mapped == NULL) { /* few ranges, or a driver that refuses the mapping */
    SubDataRanges(r, target, bytes, stride, ranges, count);
    return;
  }
  for (uint32_t i = 0; i < count; ++i) {
    const size_t offset = stride * ranges[i].first, size = stride * ranges[i].count;
    memcpy(mapped + (offset - begin), bytes + offset, size);
    glFlushMappedBufferRange(target, (GLintptr)(offset - begin), (GLsizeiptr)size);
    r->bytes_uploaded += size;
    r->upload_calls += 1;
  }
  glUnmapBuffer(target);
}

static void BindAttributes(vw_primitive* p) {
  glBindVertexArray(p->vao);
  glBindBuffer(GL_ARRAY_BUFFER, p->positions);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 12, (const void*)0);
  if (p->has_normals && p->normals != 0) {
    glBindBuffer(GL_ARRAY_BUFFER, p->normals);
    glEnableVertexAttribArray(1);
    glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 12, (const void*)0);
  } else {
    glDisableVertexAttribArray(1);
    glVertexAttrib3f(1, 0.0f, 0.0f, 1.0f);
  }
  glBindBuffer(GL_ARRAY_BUFFER, p->predicted);
  glEnableVertexAttribArray(2);
  glVertexAttribPointer(2, 1, GL_UNSIGNED_BYTE, GL_FALSE, 1, (const void*)0);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, p->indices);
  glBindVertexArray(0);
}

void vw_primitive_update(vw_renderer* r, vw_primitive* p, uint32_t vertex_count, const float* positions,
                         const float* normals, const uint8_t* predicted, const ms_range* vertex_ranges,
                         uint32_t vertex_range_count, uint32_t index_count, const uint32_t* indices,
                         const ms_range* index_ranges, uint32_t index_range_count) {
  int rebind = p->positions == 0;
  const int has_normals = normals != NULL;
  if (has_normals != p->has_normals) rebind = 1;
  p->has_normals = has_normals;
  /* The VAO must not hold the element buffer while other targets are bound: unbind it. */
  glBindVertexArray(0);
  if (vertex_count > p->vertex_capacity || p->positions == 0) {
    const uint32_t capacity = NewCapacity(p->vertex_capacity, vertex_count);
    const uint32_t valid = p->vertex_count < vertex_count ? p->vertex_count : vertex_count;
    Grow(r, GL_ARRAY_BUFFER, &p->positions, 12, valid, capacity);
    Grow(r, GL_ARRAY_BUFFER, &p->normals, 12, has_normals ? valid : 0, capacity);
    Grow(r, GL_ARRAY_BUFFER, &p->predicted, 1, valid, capacity);
    p->vertex_capacity = capacity;
    rebind = 1;
  }
  if (index_count > p->index_capacity || p->indices == 0) {
    const uint32_t capacity = NewCapacity(p->index_capacity, index_count);
    const uint32_t valid = p->index_count < index_count ? p->index_count : index_count;
    Grow(r, GL_ELEMENT_ARRAY_BUFFER, &p->indices, 4, valid, capacity);
    p->index_capacity = capacity;
    rebind = 1;
  }
  glBindBuffer(GL_ARRAY_BUFFER, p->positions);
  WriteRanges(r, GL_ARRAY_BUFFER, positions, 12, vertex_ranges, vertex_range_count);
  if (has_normals) {
    glBindBuffer(GL_ARRAY_BUFFER, p->normals);
    WriteRanges(r, GL_ARRAY_BUFFER, normals, 12, vertex_ranges, vertex_range_count);
  }
  glBindBuffer(GL_ARRAY_BUFFER, p->predicted);
  if (predicted != NULL) {
    WriteRanges(r, GL_ARRAY_BUFFER, predicted, 1, vertex_ranges, vertex_range_count);
  } else if (vertex_range_count > 0) {
    /* No flags: zeros over the ranges (a scratch of the largest range). */
    uint32_t largest = 0;
    for (uint32_t i = 0; i < vertex_range_count; ++i)
      if (vertex_ranges[i].count > largest) largest = vertex_ranges[i].count;
    uint8_t* zeros = (uint8_t*)calloc(largest, 1);
    for (uint32_t i = 0; zeros != NULL && i < vertex_range_count; ++i) {
      glBufferSubData(GL_ARRAY_BUFFER, vertex_ranges[i].first, vertex_ranges[i].count, zeros);
      r->bytes_uploaded += vertex_ranges[i].count;
      r->upload_calls += 1;
    }
    free(zeros);
  }
  glBindBuffer(GL_ARRAY_BUFFER, 0);
  /* The element buffer through GL_COPY_WRITE_BUFFER: no VAO is bound, and
   * binding GL_ELEMENT_ARRAY_BUFFER without one is not core GL. */
  glBindBuffer(GL_COPY_WRITE_BUFFER, p->indices);
  WriteRanges(r, GL_COPY_WRITE_BUFFER, indices, 4, index_ranges, index_range_count);
  glBindBuffer(GL_COPY_WRITE_BUFFER, 0);
  if (rebind) BindAttributes(p);
  p->vertex_count = vertex_count;
  p->index_count = index_count;
}

static int Differs(GLuint buffer, const void* data, size_t size) {
  if (size == 0) return 0;
  if (data == NULL || buffer == 0) return 1;
  void* back = malloc(size);
  if (back == NULL) return 1;
  glBindBuffer(GL_COPY_READ_BUFFER, buffer);
  glGetBufferSubData(GL_COPY_READ_BUFFER, 0, (GLsizeiptr)size, back);
  glBindBuffer(GL_COPY_READ_BUFFER, 0);
  const int differs = memcmp(back, data, size) != 0;
  free(back);
  return differs;
}

int vw_primitive_verify(const vw_primitive* p, const float* positions, const float* normals,
                        const uint8_t* predicted, const uint32_t* indices) {
  int bad = 0;
  bad += Differs(p->positions, positions, 12u * p->vertex_count);
  if (normals != NULL) bad += Differs(p->normals, normals, 12u * p->vertex_count);
  if (predicted != NULL) bad += Differs(p->predicted, predicted, p->vertex_count);
  bad += Differs(p->indices, indices, 4u * p->index_count);
  return bad;
}

void vw_draw(const vw_renderer* r, const vw_primitive* primitives, uint32_t count, const float view_projection[16],
             int tint_predicted, int width, int height) {
  glViewport(0, 0, width, height);
  glClearColor(vw_background[0] / 255.0f, vw_background[1] / 255.0f, vw_background[2] / 255.0f, 1.0f);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glEnable(GL_DEPTH_TEST);
  glDisable(GL_CULL_FACE); /* glTF's double-sided and open meshes alike */
  glUseProgram(r->program);
  glUniformMatrix4fv(r->u_view_projection, 1, GL_FALSE, view_projection);
  glUniform1i(r->u_tint, tint_predicted);
  for (uint32_t i = 0; i < count; ++i) {
    const vw_primitive* p = &primitives[i];
    if (p->index_count == 0 || p->positions == 0) continue;
    glUniform1i(r->u_has_normals, p->has_normals);
    glBindVertexArray(p->vao);
    for (uint32_t k = 0; k < p->instance_count; ++k) {
      glUniformMatrix4fv(r->u_model, 1, GL_FALSE, p->instances + 16 * k);
      glDrawElements(GL_TRIANGLES, (GLsizei)p->index_count, GL_UNSIGNED_INT, (const void*)0);
    }
  }
  glBindVertexArray(0);
}

void vw_read_pixels(int width, int height, uint8_t* rgb) {
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadBuffer(GL_BACK);
  uint8_t* flipped = (uint8_t*)malloc((size_t)width * height * 3);
  if (flipped == NULL) return;
  glReadPixels(0, 0, width, height, GL_RGB, GL_UNSIGNED_BYTE, flipped);
  for (int y = 0; y < height; ++y)
    memcpy(rgb + (size_t)y * width * 3, flipped + (size_t)(height - 1 - y) * width * 3, (size_t)width * 3);
  free(flipped);
}

int vw_write_ppm(const char* path, int width, int height, const uint8_t* rgb) {
  FILE* f = fopen(path, "wb");
  if (f == NULL) return -1;
  fprintf(f, "P6\n%d %d\n255\n", width, height);
  const size_t n = (size_t)width * height * 3;
  const int ok = fwrite(rgb, 1, n, f) == n;
  return (fclose(f) == 0 && ok) ? 0 : -1;
}

void vw_perspective(float fov_y_degrees, float aspect, float near_plane, float far_plane, float out[16]) {
  const float f = 1.0f / tanf(fov_y_degrees * 3.14159265f / 360.0f);
  memset(out, 0, 16 * sizeof(float));
  out[0] = f / aspect;
  out[5] = f;
  out[10] = (far_plane + near_plane) / (near_plane - far_plane);
  out[11] = -1.0f;
  out[14] = 2.0f * far_plane * near_plane / (near_plane - far_plane);
}

static void Normalize(float v[3]) {
  const float l = sqrtf(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  if (l > 0) {
    v[0] /= l;
    v[1] /= l;
    v[2] /= l;
  }
}

void vw_look_at(const float eye[3], const float target[3], const float up[3], float out[16]) {
  float f[3] = {target[0] - eye[0], target[1] - eye[1], target[2] - eye[2]};
  Normalize(f);
  float s[3] = {f[1] * up[2] - f[2] * up[1], f[2] * up[0] - f[0] * up[2], f[0] * up[1] - f[1] * up[0]};
  Normalize(s);
  const float u[3] = {s[1] * f[2] - s[2] * f[1], s[2] * f[0] - s[0] * f[2], s[0] * f[1] - s[1] * f[0]};
  memset(out, 0, 16 * sizeof(float));
  out[0] = s[0];
  out[4] = s[1];
  out[8] = s[2];
  out[1] = u[0];
  out[5] = u[1];
  out[9] = u[2];
  out[2] = -f[0];
  out[6] = -f[1];
  out[10] = -f[2];
  out[12] = -(s[0] * eye[0] + s[1] * eye[1] + s[2] * eye[2]);
  out[13] = -(u[0] * eye[0] + u[1] * eye[1] + u[2] * eye[2]);
  out[14] = f[0] * eye[0] + f[1] * eye[1] + f[2] * eye[2];
  out[15] = 1.0f;
}

void vw_multiply(const float a[16], const float b[16], float out[16]) {
  float t[16];
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r) {
      float s = 0;
      for (int k = 0; k < 4; ++k) s += a[k * 4 + r] * b[c * 4 + k];
      t[c * 4 + r] = s;
    }
  memcpy(out, t, sizeof t);
}
