/* meshstream_viewer: a native viewer that streams an asset through the C API
 * (sdk/include/meshstream/meshstream.h) on a frame budget, the worked example
 * of docs/engine-integration.md.
 *
 *   meshstream_viewer [options] ASSET
 *
 * Each frame: one ms_session_poll with timeout 0 (it never waits and never
 * decodes: the session's own thread does), then, while the frame's budget
 * lasts, one primitive at a time brought up to date on the GPU by the ranges
 * ms_session_mesh_changes gives; then the draw. It does not poll again until
 * the event's primitives are all on the GPU (the views stay valid until the
 * next poll), so a frame never waits for the network or for a whole scene.
 * --min-update-ms N shows a level at most every N ms (the SDK merges the levels
 * between into one event): fewer, larger updates, fewer bytes uploaded.
 * Mouse: drag to orbit, wheel to zoom; P tints predicted vertices; Esc quits.
 * The camera goes to the server as the view when it moved (at most every
 * 250 ms). The window's title shows level, vertices, bytes and times.
 *
 * For tests and benchmarks: --capture DIR (a PPM per level shown and
 * final.ppm), --stats FILE (JSON: per level the counts drawn and the SDK's,
 * uploads, frame and poll times), --verify (read the GPU buffers back after
 * each upload and compare them with the views), --exit-when-complete,
 * --idle-frames N (frames drawn after COMPLETE, timed as the idle figure),
 * --export PATH (ms_session_export at COMPLETE), --tint (and final-untinted.ppm
 * beside final.ppm), --udp-via and --no-parity (a lossy relay's test). */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include "meshstream/meshstream.h"
#include "render.h"

typedef struct {
  const char* server;
  const char* token;
  const char* asset;
  int64_t version;
  int tcp_only;
  int width, height;
  int64_t budget_us;
  int64_t min_update_ms;
  uint32_t max_ranges;
  const char* capture_dir;
  const char* stats_path;
  const char* export_path;
  int verify;
  int exit_when_complete;
  int idle_frames;
  int send_view;
  int has_look;
  float eye[3], target[3], fov;
  int swap_interval;
  const char* udp_via;
  int no_parity;
  int tint;
} Options;

static void Usage(FILE* f) {
  fprintf(f,
          "usage: meshstream_viewer [options] ASSET\n"
          "  --server HOST:PORT     the meshstream server (default 127.0.0.1:7600)\n"
          "  --token T              bearer token (also MESHSTREAM_TOKEN)\n"
          "  --version N            the asset version (default: the latest READY)\n"
          "  --tcp-only             everything over the gRPC stream\n"
          "  --size WxH             window size (default 960x720)\n"
          "  --budget-us N          per-frame time for polling and uploads (default 2000)\n"
          "  --max-ranges N         merge changed ranges down to N per array (default 0: exact)\n"
          "  --min-update-ms N      show a new level at most every N ms (the levels between merge; default 0)\n"
          "  --look EX,EY,EZ,TX,TY,TZ[,FOV]  the camera (default: framing the base)\n"
          "  --no-view              do not send the camera to the server\n"
          "  --tint                 start with predicted vertices tinted (key P toggles)\n"
          "  --udp-via HOST:PORT    send the UDP half there (a relay) instead of the server's address\n"
          "  --no-parity            no parity datagrams: what UDP loses is predicted\n"
          "  --vsync                wait for the display's refresh (default: off)\n"
          "  --capture DIR          write DIR/level-NN.ppm per level shown and DIR/final.ppm\n"
          "  --stats FILE           write counts, uploads and times as JSON at the end\n"
          "  --verify               read GPU buffers back after each upload and compare\n"
          "  --export PATH          write the final scene (.glb or .gltf) at COMPLETE\n"
          "  --exit-when-complete   close after COMPLETE (and --idle-frames)\n"
          "  --idle-frames N        frames drawn after COMPLETE before closing (default 0)\n");
}

static int ParseInt(const char* s, long long lo, long long hi, long long* out) {
  char* end = NULL;
  errno = 0;
  const long long v = strtoll(s, &end, 10);
  if (errno != 0 || end == s || *end != '\0' || v < lo || v > hi) return -1;
  *out = v;
  return 0;
}

static int ParseLook(const char* s, Options* o) {
  float v[7];
  int n = 0;
  const char* p = s;
  while (n < 7) {
    char* end = NULL;
    v[n] = strtof(p, &end);
    if (end == p || !isfinite(v[n])) return -1;
    ++n;
    if (*end == '\0') break;
    if (*end != ',') return -1;
    p = end + 1;
  }
  if (n != 6 && n != 7) return -1;
  for (int i = 0; i < 3; ++i) {
    o->eye[i] = v[i];
    o->target[i] = v[3 + i];
  }
  if (o->eye[0] == o->target[0] && o->eye[1] == o->target[1] && o->eye[2] == o->target[2]) return -1;
  o->fov = n == 7 ? v[6] : 45.0f;
  if (!(o->fov > 1.0f && o->fov < 179.0f)) return -1;
  o->has_look = 1;
  return 0;
}

/* 0: go on; 1: exit 0 (help); 2: usage error. */
static int ParseArgs(int argc, char** argv, Options* o) {
  memset(o, 0, sizeof *o);
  o->server = "127.0.0.1:7600";
  o->token = getenv("MESHSTREAM_TOKEN");
  o->width = 960;
  o->height = 720;
  o->budget_us = 2000;
  o->send_view = 1;
  for (int i = 1; i < argc; ++i) {
    const char* a = argv[i];
    const char* next = i + 1 < argc ? argv[i + 1] : NULL;
    long long v = 0;
#define NEED(name)                                                   \
  if (next == NULL) {                                                \
    fprintf(stderr, "meshstream_viewer: %s needs a value\n", name); \
    return 2;                                                        \
  }                                                                  \
  ++i;
    if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
      Usage(stdout);
      return 1;
    } else if (strcmp(a, "--server") == 0) {
      NEED(a) o->server = next;
    } else if (strcmp(a, "--token") == 0) {
      NEED(a) o->token = next;
    } else if (strcmp(a, "--version") == 0) {
      NEED(a) if (ParseInt(next, 0, INT64_MAX, &v) != 0) {
        fprintf(stderr, "meshstream_viewer: --version: not a version number: %s\n", next);
        return 2;
      }
      o->version = v;
    } else if (strcmp(a, "--tcp-only") == 0) {
      o->tcp_only = 1;
    } else if (strcmp(a, "--size") == 0) {
      NEED(a) int w = 0, h = 0;
      char tail = 0;
      if (sscanf(next, "%dx%d%c", &w, &h, &tail) != 2 || w < 16 || h < 16 || w > 8192 || h > 8192) {
        fprintf(stderr, "meshstream_viewer: --size: WxH with each 16..8192: %s\n", next);
        return 2;
      }
      o->width = w;
      o->height = h;
    } else if (strcmp(a, "--budget-us") == 0) {
      NEED(a) if (ParseInt(next, 0, 1000000, &v) != 0) {
        fprintf(stderr, "meshstream_viewer: --budget-us: 0..1000000: %s\n", next);
        return 2;
      }
      o->budget_us = v;
    } else if (strcmp(a, "--min-update-ms") == 0) {
      NEED(a) if (ParseInt(next, 0, 600000, &v) != 0) {
        fprintf(stderr, "meshstream_viewer: --min-update-ms: 0..600000: %s\n", next);
        return 2;
      }
      o->min_update_ms = v;
    } else if (strcmp(a, "--max-ranges") == 0) {
      NEED(a) if (ParseInt(next, 0, 1 << 30, &v) != 0) {
        fprintf(stderr, "meshstream_viewer: --max-ranges: a count: %s\n", next);
        return 2;
      }
      o->max_ranges = (uint32_t)v;
    } else if (strcmp(a, "--look") == 0) {
      NEED(a) if (ParseLook(next, o) != 0) {
        fprintf(stderr, "meshstream_viewer: --look: EX,EY,EZ,TX,TY,TZ[,FOV] (eye != target, FOV 1..179): %s\n", next);
        return 2;
      }
    } else if (strcmp(a, "--tint") == 0) {
      o->tint = 1;
    } else if (strcmp(a, "--udp-via") == 0) {
      NEED(a) o->udp_via = next;
    } else if (strcmp(a, "--no-parity") == 0) {
      o->no_parity = 1;
    } else if (strcmp(a, "--no-view") == 0) {
      o->send_view = 0;
    } else if (strcmp(a, "--vsync") == 0) {
      o->swap_interval = 1;
    } else if (strcmp(a, "--capture") == 0) {
      NEED(a) o->capture_dir = next;
    } else if (strcmp(a, "--stats") == 0) {
      NEED(a) o->stats_path = next;
    } else if (strcmp(a, "--export") == 0) {
      NEED(a) o->export_path = next;
    } else if (strcmp(a, "--verify") == 0) {
      o->verify = 1;
    } else if (strcmp(a, "--exit-when-complete") == 0) {
      o->exit_when_complete = 1;
    } else if (strcmp(a, "--idle-frames") == 0) {
      NEED(a) if (ParseInt(next, 0, 1000000, &v) != 0) {
        fprintf(stderr, "meshstream_viewer: --idle-frames: a count: %s\n", next);
        return 2;
      }
      o->idle_frames = (int)v;
    } else if (a[0] == '-') {
      fprintf(stderr, "meshstream_viewer: unknown option %s\n", a);
      Usage(stderr);
      return 2;
    } else if (o->asset == NULL) {
      o->asset = a;
    } else {
      fprintf(stderr, "meshstream_viewer: one asset only (got %s and %s)\n", o->asset, a);
      return 2;
    }
#undef NEED
  }
  if (o->asset == NULL) {
    Usage(stderr);
    return 2;
  }
  return 0;
}

static double NowUs(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (double)t.tv_sec * 1e6 + (double)t.tv_nsec / 1e3;
}

/* A growing array of doubles (frame times). */
typedef struct {
  double* v;
  size_t n, cap;
} Series;

static void Push(Series* s, double x) {
  if (s->n == s->cap) {
    size_t cap = s->cap ? 2 * s->cap : 256;
    double* v = (double*)realloc(s->v, cap * sizeof(double));
    if (v == NULL) return;
    s->v = v;
    s->cap = cap;
  }
  s->v[s->n++] = x;
}

static int Compare(const void* a, const void* b) {
  const double x = *(const double*)a, y = *(const double*)b;
  return x < y ? -1 : x > y;
}

/* The q-quantile (nearest rank) of the series; 0 when empty. */
static double Quantile(const Series* s, double q) {
  if (s->n == 0) return 0;
  double* c = (double*)malloc(s->n * sizeof(double));
  if (c == NULL) return 0;
  memcpy(c, s->v, s->n * sizeof(double));
  qsort(c, s->n, sizeof(double), Compare);
  size_t k = (size_t)ceil(q * (double)s->n);
  if (k < 1) k = 1;
  const double r = c[k - 1];
  free(c);
  return r;
}

typedef struct {
  int32_t level;
  uint64_t drawn_vertices, drawn_indices; /* what the GPU buffers hold and the draw uses */
  uint64_t sdk_vertices, sdk_indices;     /* the views' counts */
  uint64_t changed_vertices, changed_indices;
  uint64_t bytes_uploaded_after;          /* the renderer's total once this level was on the GPU */
  uint32_t frames;                        /* frames the level's uploads took */
  uint64_t nonblank_pixels;               /* pixels not the background in the frame that showed it */
  uint64_t buffer_bytes;                  /* the drawn buffers' size at this level (a whole re-upload) */
} LevelRecord;

typedef struct {
  /* camera */
  float yaw, pitch, distance, target[3], fov, radius;
  int camera_set, camera_moved;
  double last_view_sent_us;
  int dragging;
  double drag_x, drag_y;
  int tint;
} Camera;

static Camera camera;

static void OnCursor(GLFWwindow* w, double x, double y) {
  (void)w;
  if (camera.dragging) {
    camera.yaw -= (float)(x - camera.drag_x) * 0.01f;
    camera.pitch += (float)(y - camera.drag_y) * 0.01f;
    if (camera.pitch > 1.5f) camera.pitch = 1.5f;
    if (camera.pitch < -1.5f) camera.pitch = -1.5f;
    camera.camera_moved = 1;
  }
  camera.drag_x = x;
  camera.drag_y = y;
}

static void OnButton(GLFWwindow* w, int button, int action, int mods) {
  (void)w;
  (void)mods;
  if (button == GLFW_MOUSE_BUTTON_LEFT) camera.dragging = action == GLFW_PRESS;
}

static void OnScroll(GLFWwindow* w, double dx, double dy) {
  (void)w;
  (void)dx;
  camera.distance *= (float)pow(0.9, dy);
  camera.camera_moved = 1;
}

static void OnKey(GLFWwindow* w, int key, int scancode, int action, int mods) {
  (void)scancode;
  (void)mods;
  if (action != GLFW_PRESS) return;
  if (key == GLFW_KEY_ESCAPE) glfwSetWindowShouldClose(w, GLFW_TRUE);
  if (key == GLFW_KEY_P) camera.tint = !camera.tint;
}

static void Eye(float eye[3]) {
  eye[0] = camera.target[0] + camera.distance * cosf(camera.pitch) * sinf(camera.yaw);
  eye[1] = camera.target[1] + camera.distance * sinf(camera.pitch);
  eye[2] = camera.target[2] + camera.distance * cosf(camera.pitch) * cosf(camera.yaw);
}

static void ViewProjection(int width, int height, float out[16], float eye_out[3]) {
  float eye[3];
  Eye(eye);
  const float up[3] = {0, 1, 0};
  float view[16], projection[16];
  vw_look_at(eye, camera.target, up, view);
  float near_plane = camera.distance - 2.0f * camera.radius;
  const float far_plane = camera.distance + 2.0f * camera.radius;
  if (near_plane < far_plane * 1e-3f) near_plane = far_plane * 1e-3f;
  vw_perspective(camera.fov, (float)width / (float)height, near_plane, far_plane, projection);
  vw_multiply(projection, view, out);
  memcpy(eye_out, eye, sizeof eye);
}

/* The camera from --look, or one that frames the base's bounds. */
static void SetCamera(const Options* o, ms_session* session) {
  float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  const uint32_t count = ms_session_primitive_count(session);
  for (uint32_t i = 0; i < count; ++i) {
    ms_mesh_view v;
    const float* m = NULL;
    uint32_t instances = 0;
    if (ms_session_mesh(session, i, &v) != MS_OK || ms_session_instances(session, i, &m, &instances) != MS_OK) continue;
    for (uint32_t k = 0; k < instances; ++k) {
      const float* M = m + 16 * k;
      for (size_t j = 0; j < v.vertex_count; ++j) {
        const float* p = v.positions + 3 * j;
        for (int a = 0; a < 3; ++a) {
          const float w = M[a] * p[0] + M[4 + a] * p[1] + M[8 + a] * p[2] + M[12 + a];
          if (w < lo[a]) lo[a] = w;
          if (w > hi[a]) hi[a] = w;
        }
      }
    }
  }
  float radius = 0;
  for (int a = 0; a < 3; ++a) {
    if (!(lo[a] <= hi[a])) lo[a] = hi[a] = 0;
    const float h = 0.5f * (hi[a] - lo[a]);
    radius += h * h;
  }
  radius = sqrtf(radius);
  if (!(radius > 0)) radius = 1;
  camera.radius = radius;
  if (o->has_look) {
    const float d[3] = {o->eye[0] - o->target[0], o->eye[1] - o->target[1], o->eye[2] - o->target[2]};
    camera.distance = sqrtf(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    memcpy(camera.target, o->target, sizeof camera.target);
    camera.pitch = asinf(d[1] / camera.distance);
    camera.yaw = atan2f(d[0], d[2]);
    camera.fov = o->fov;
    if (camera.radius < camera.distance * 0.01f) camera.radius = camera.distance * 0.01f;
  } else {
    for (int a = 0; a < 3; ++a) camera.target[a] = 0.5f * (lo[a] + hi[a]);
    camera.fov = 45.0f;
    camera.distance = radius / sinf(camera.fov * 3.14159265f / 360.0f) * 1.05f;
    camera.yaw = 0.6f;
    camera.pitch = 0.35f;
  }
  camera.camera_set = 1;
  camera.camera_moved = 1;
}

static void FillView(int width, int height, ms_view* view) {
  float vp[16], eye[3];
  ViewProjection(width, height, vp, eye);
  memset(view, 0, sizeof *view);
  for (int i = 0; i < 3; ++i) view->camera_position[i] = eye[i];
  for (int i = 0; i < 16; ++i) view->view_projection[i] = vp[i];
  view->viewport_width = (uint32_t)width;
  view->viewport_height = (uint32_t)height;
}

static int Capture(const Options* o, const char* name, int width, int height, uint8_t* rgb, uint64_t* nonblank) {
  vw_read_pixels(width, height, rgb);
  uint64_t n = 0;
  for (size_t i = 0; i < (size_t)width * height; ++i) {
    const uint8_t* p = rgb + 3 * i;
    if (p[0] != vw_background[0] || p[1] != vw_background[1] || p[2] != vw_background[2]) ++n;
  }
  *nonblank = n;
  if (o->capture_dir == NULL) return 0;
  char path[4096];
  snprintf(path, sizeof path, "%s/%s.ppm", o->capture_dir, name);
  if (vw_write_ppm(path, width, height, rgb) != 0) {
    fprintf(stderr, "meshstream_viewer: cannot write %s: %s\n", path, strerror(errno));
    return -1;
  }
  return 0;
}

int main(int argc, char** argv) {
  Options o;
  const int parsed = ParseArgs(argc, argv, &o);
  if (parsed != 0) return parsed == 1 ? 0 : 2;

  if (!glfwInit()) {
    const char* why = NULL;
    glfwGetError(&why);
    fprintf(stderr, "meshstream_viewer: no display: %s (set DISPLAY, or run under xvfb-run)\n", why ? why : "?");
    return 1;
  }
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  glfwWindowHint(GLFW_RESIZABLE, GLFW_FALSE);
  GLFWwindow* window = glfwCreateWindow(o.width, o.height, "meshstream", NULL, NULL);
  if (window == NULL) {
    const char* why = NULL;
    glfwGetError(&why);
    fprintf(stderr, "meshstream_viewer: no OpenGL 3.3 core context: %s\n", why ? why : "?");
    glfwTerminate();
    return 1;
  }
  glfwMakeContextCurrent(window);
  glfwSwapInterval(o.swap_interval);
  glfwSetCursorPosCallback(window, OnCursor);
  glfwSetMouseButtonCallback(window, OnButton);
  glfwSetScrollCallback(window, OnScroll);
  glfwSetKeyCallback(window, OnKey);
  int fb_width = o.width, fb_height = o.height;
  glfwGetFramebufferSize(window, &fb_width, &fb_height);

  vw_renderer renderer;
  const char* gl_error = NULL;
  if (vw_renderer_init(&renderer, &gl_error) != 0) {
    fprintf(stderr, "meshstream_viewer: shaders: %s\n", gl_error);
    return 1;
  }

  ms_client_config cc;
  memset(&cc, 0, sizeof cc);
  cc.struct_size = sizeof cc;
  cc.server = o.server;
  cc.token = o.token;
  ms_client* client = NULL;
  if (ms_client_create(&cc, &client) != MS_OK) {
    fprintf(stderr, "meshstream_viewer: %s\n", ms_last_error());
    return 1;
  }
  ms_session_config sc;
  memset(&sc, 0, sizeof sc);
  sc.struct_size = sizeof sc;
  sc.asset = o.asset;
  sc.version = o.version;
  sc.max_level = -1;
  sc.tcp_only = o.tcp_only;
  sc.udp_via = o.udp_via;
  sc.no_parity = o.no_parity;
  camera.tint = o.tint;
  ms_session* session = NULL;
  if (ms_session_open(client, &sc, &session) != MS_OK) {
    fprintf(stderr, "meshstream_viewer: %s\n", ms_last_error());
    ms_client_destroy(client);
    return 1;
  }

  vw_primitive* primitives = NULL;
  uint32_t primitive_count = 0;
  LevelRecord* levels = NULL;
  size_t level_records = 0;
  Series refining_frames = {0}, refining_draw = {0}, idle_frames = {0}, stream_us = {0};
  uint8_t* rgb = (uint8_t*)malloc((size_t)fb_width * fb_height * 3);
  int exit_code = 0;
  int pending = 0;          /* an event whose primitives are not all on the GPU yet */
  uint32_t next_primitive = 0;
  ms_event event;
  memset(&event, 0, sizeof event);
  int complete = 0, idle_drawn = 0, base_seen = 0;
  uint64_t verify_mismatches = 0, frames_over_budget = 0;
  uint32_t most_primitives_in_a_frame = 0;
  double max_stream_us = 0;
  uint32_t event_frames = 0;
  uint64_t final_vertices = 0, final_indices = 0;
  double last_title_us = 0, last_update_us = -1e18;
  const double opened_us = NowUs();

  while (!glfwWindowShouldClose(window)) {
    const double frame_start = NowUs();
    const double deadline = frame_start + (double)o.budget_us;
    glfwPollEvents();

    /* The stream's part of the frame: a poll, or uploads of the event's primitives. */
    const double stream_start = NowUs();
    if (!pending && !complete && frame_start - last_update_us >= 1000.0 * (double)o.min_update_ms) {
      if (ms_session_poll(session, 0, &event) != MS_OK && event.type != MS_EVENT_ERROR) {
        fprintf(stderr, "meshstream_viewer: poll: %s\n", ms_last_error());
        exit_code = 1;
        break;
      }
      if (event.type == MS_EVENT_ERROR) {
        fprintf(stderr, "meshstream_viewer: %s: %s\n", ms_status_name(event.status), ms_last_error());
        exit_code = 1;
        break;
      }
      if (event.type == MS_EVENT_BASE_READY || event.type == MS_EVENT_LEVEL_READY || event.type == MS_EVENT_COMPLETE) {
        const uint32_t count = ms_session_primitive_count(session);
        if (count > primitive_count) {
          vw_primitive* grown = (vw_primitive*)realloc(primitives, count * sizeof(vw_primitive));
          if (grown == NULL) {
            fprintf(stderr, "meshstream_viewer: out of memory\n");
            exit_code = 1;
            break;
          }
          primitives = grown;
          for (uint32_t i = primitive_count; i < count; ++i) {
            vw_primitive_init(&primitives[i]);
            const float* m = NULL;
            uint32_t instances = 0;
            if (ms_session_instances(session, i, &m, &instances) == MS_OK) vw_primitive_set_instances(&primitives[i], m, instances);
          }
          primitive_count = count;
        }
        if (!base_seen) {
          base_seen = 1;
          if (!camera.camera_set) SetCamera(&o, session);
        }
        LevelRecord* grown = (LevelRecord*)realloc(levels, (level_records + 1) * sizeof(LevelRecord));
        if (grown == NULL) {
          fprintf(stderr, "meshstream_viewer: out of memory\n");
          exit_code = 1;
          break;
        }
        levels = grown;
        memset(&levels[level_records], 0, sizeof(LevelRecord));
        levels[level_records].level = event.level;
        ++level_records;
        pending = 1;
        next_primitive = 0;
        event_frames = 0;
      }
    }
    /* Not polled while uploading: the views stay valid until the next poll. */
    int level_shown = 0;
    if (pending) {
      ++event_frames;
      LevelRecord* rec = &levels[level_records - 1];
      uint32_t done_this_frame = 0;
      while (next_primitive < primitive_count) {
        if (done_this_frame > 0 && NowUs() >= deadline) break; /* the rest next frame; at least one per frame */
        const uint32_t i = next_primitive;
        ms_mesh_changes changes;
        memset(&changes, 0, sizeof changes);
        changes.struct_size = sizeof changes;
        changes.max_ranges = o.max_ranges;
        ms_mesh_view v;
        if (ms_session_mesh_changes(session, i, &changes) != MS_OK || ms_session_mesh(session, i, &v) != MS_OK) {
          fprintf(stderr, "meshstream_viewer: primitive %u: %s\n", i, ms_last_error());
          exit_code = 1;
          break;
        }
        vw_primitive_update(&renderer, &primitives[i], (uint32_t)v.vertex_count, v.positions, v.normals, v.predicted,
                            changes.vertex_ranges, changes.vertex_range_count, (uint32_t)v.index_count, v.indices,
                            changes.index_ranges, changes.index_range_count);
        if (o.verify) verify_mismatches += (uint64_t)vw_primitive_verify(&primitives[i], v.positions, v.normals, v.predicted, v.indices);
        rec->sdk_vertices += v.vertex_count;
        rec->sdk_indices += v.index_count;
        rec->changed_vertices += changes.changed_vertices;
        rec->changed_indices += changes.changed_indices;
        ++next_primitive;
        ++done_this_frame;
      }
      if (exit_code != 0) break;
      if (done_this_frame > most_primitives_in_a_frame) most_primitives_in_a_frame = done_this_frame;
      if (next_primitive == primitive_count) {
        pending = 0;
        rec->frames = event_frames;
        for (uint32_t i = 0; i < primitive_count; ++i) {
          rec->drawn_vertices += primitives[i].vertex_count;
          rec->drawn_indices += primitives[i].index_count;
          rec->buffer_bytes += (uint64_t)primitives[i].vertex_count * (12u + (primitives[i].has_normals ? 12u : 0u) + 1u) +
                               4ull * primitives[i].index_count;
        }
        rec->bytes_uploaded_after = renderer.bytes_uploaded;
        last_update_us = NowUs();
        if (event.type == MS_EVENT_COMPLETE) complete = 1;
        level_shown = 1;
      }
    }
    const double stream_time = NowUs() - stream_start;
    Push(&stream_us, stream_time);
    if (stream_time > max_stream_us) max_stream_us = stream_time;
    if (stream_time > (double)o.budget_us) ++frames_over_budget;

    /* The view: when the camera moved, at most every 250 ms. */
    if (o.send_view && camera.camera_set && camera.camera_moved && frame_start - camera.last_view_sent_us >= 250e3 && !complete) {
      ms_view view;
      FillView(fb_width, fb_height, &view);
      if (ms_session_set_view(session, &view) == MS_OK) {
        camera.camera_moved = 0;
        camera.last_view_sent_us = frame_start;
      }
    }

    float vp[16], eye[3];
    if (camera.camera_set) {
      ViewProjection(fb_width, fb_height, vp, eye);
    } else {
      memset(vp, 0, sizeof vp);
    }
    vw_draw(&renderer, primitives, primitive_count, vp, camera.tint, fb_width, fb_height);
    if (level_shown && rgb != NULL) {
      LevelRecord* rec = &levels[level_records - 1];
      char name[64];
      snprintf(name, sizeof name, "level-%02d", rec->level);
      if (Capture(&o, name, fb_width, fb_height, rgb, &rec->nonblank_pixels) != 0) {
        exit_code = 1;
        break;
      }
      if (o.stats_path != NULL) {
        fprintf(stderr, "level %d: %llu vertices, %llu indices drawn in %u frames, %llu pixels drawn\n", rec->level,
                (unsigned long long)rec->drawn_vertices, (unsigned long long)rec->drawn_indices, rec->frames,
                (unsigned long long)rec->nonblank_pixels);
      }
    }
    if (level_shown && complete) { /* the COMPLETE event's meshes are on the GPU and drawn: the final frame */
      uint64_t nonblank = 0;
      if (rgb != NULL && Capture(&o, "final", fb_width, fb_height, rgb, &nonblank) != 0) {
        exit_code = 1;
        break;
      }
      if (camera.tint && rgb != NULL) { /* the same frame untinted, for comparison; then tinted again */
        vw_draw(&renderer, primitives, primitive_count, vp, 0, fb_width, fb_height);
        if (Capture(&o, "final-untinted", fb_width, fb_height, rgb, &nonblank) != 0) {
          exit_code = 1;
          break;
        }
        vw_draw(&renderer, primitives, primitive_count, vp, 1, fb_width, fb_height);
      }
      if (o.export_path != NULL && ms_session_export(session, o.export_path) != MS_OK) {
        fprintf(stderr, "meshstream_viewer: export: %s\n", ms_last_error());
        exit_code = 1;
        break;
      }
      for (uint32_t i = 0; i < primitive_count; ++i) {
        final_vertices += primitives[i].vertex_count;
        final_indices += primitives[i].index_count;
      }
    }
    glFinish();
    const double frame_end = NowUs();
    if (complete && !pending) {
      if (idle_drawn > 0) Push(&idle_frames, (frame_end - frame_start) / 1000.0);
    } else if (base_seen) {
      Push(&refining_frames, (frame_end - frame_start) / 1000.0);
      Push(&refining_draw, (frame_end - frame_start - stream_time) / 1000.0); /* the same frame without the stream's part */
    }
    glfwSwapBuffers(window);

    if (frame_end - last_title_us > 250e3) {
      ms_stats s;
      memset(&s, 0, sizeof s);
      s.struct_size = sizeof s;
      ms_session_stats(session, &s);
      uint64_t vertices = 0;
      for (uint32_t i = 0; i < primitive_count; ++i) vertices += primitives[i].vertex_count;
      char title[256];
      snprintf(title, sizeof title, "meshstream: %s  level %d/%d  %llu vertices  %.2f MB  %.0f ms%s", o.asset,
               s.level_shown, s.levels, (unsigned long long)vertices,
               (double)(s.reliable_bytes + s.unreliable_bytes) / 1e6, (frame_end - opened_us) / 1000.0,
               camera.tint ? "  [predicted tinted]" : "");
      glfwSetWindowTitle(window, title);
      last_title_us = frame_end;
    }

    if (complete && !pending) {
      ++idle_drawn;
      if (o.exit_when_complete && idle_drawn > o.idle_frames) break;
    }
  }

  if (o.stats_path != NULL) {
    FILE* f = fopen(o.stats_path, "w");
    if (f == NULL) {
      fprintf(stderr, "meshstream_viewer: cannot write %s: %s\n", o.stats_path, strerror(errno));
      exit_code = 1;
    } else {
      ms_stats s;
      memset(&s, 0, sizeof s);
      s.struct_size = sizeof s;
      ms_session_stats(session, &s);
      uint64_t final_buffer_bytes = 0;
      for (uint32_t i = 0; i < primitive_count; ++i) {
        const vw_primitive* p = &primitives[i];
        final_buffer_bytes += (uint64_t)p->vertex_count * (12u + (p->has_normals ? 12u : 0u) + 1u) + 4ull * p->index_count;
      }
      uint64_t reupload_bytes = 0; /* uploading every level's whole mesh */
      for (size_t k = 0; k < level_records; ++k) {
        reupload_bytes += levels[k].buffer_bytes;
      }
      fprintf(f, "{\n  \"asset\": \"%s\",\n  \"complete\": %s,\n  \"primitives\": %u,\n", o.asset,
              complete ? "true" : "false", primitive_count);
      fprintf(f, "  \"transport\": \"%s\",\n  \"levels\": [\n", s.transport ? s.transport : "");
      for (size_t k = 0; k < level_records; ++k) {
        const LevelRecord* r = &levels[k];
        fprintf(f,
                "    {\"level\": %d, \"drawn_vertices\": %llu, \"drawn_indices\": %llu, \"sdk_vertices\": %llu, "
                "\"sdk_indices\": %llu, \"changed_vertices\": %llu, \"changed_indices\": %llu, "
                "\"bytes_uploaded_after\": %llu, \"frames\": %u, \"nonblank_pixels\": %llu}%s\n",
                r->level, (unsigned long long)r->drawn_vertices, (unsigned long long)r->drawn_indices,
                (unsigned long long)r->sdk_vertices, (unsigned long long)r->sdk_indices,
                (unsigned long long)r->changed_vertices, (unsigned long long)r->changed_indices,
                (unsigned long long)r->bytes_uploaded_after, r->frames, (unsigned long long)r->nonblank_pixels,
                k + 1 < level_records ? "," : "");
      }
      fprintf(f, "  ],\n");
      {
        float vp[16], eye[3];
        ViewProjection(fb_width, fb_height, vp, eye);
        fprintf(f, "  \"size\": [%d, %d],\n  \"view_projection\": [", fb_width, fb_height);
        for (int i = 0; i < 16; ++i) fprintf(f, "%.9g%s", vp[i], i < 15 ? ", " : "],\n");
      }
      fprintf(f, "  \"final_vertices\": %llu,\n  \"final_indices\": %llu,\n", (unsigned long long)final_vertices,
              (unsigned long long)final_indices);
      fprintf(f, "  \"bytes_uploaded\": %llu,\n  \"bytes_copied_on_gpu\": %llu,\n  \"upload_calls\": %llu,\n",
              (unsigned long long)renderer.bytes_uploaded, (unsigned long long)renderer.bytes_copied,
              (unsigned long long)renderer.upload_calls);
      fprintf(f, "  \"final_buffer_bytes\": %llu,\n  \"upload_ratio\": %.4f,\n  \"reupload_bytes\": %llu,\n",
              (unsigned long long)final_buffer_bytes,
              final_buffer_bytes ? (double)renderer.bytes_uploaded / (double)final_buffer_bytes : 0.0,
              (unsigned long long)reupload_bytes);
      fprintf(f, "  \"verify\": %s,\n  \"verify_mismatches\": %llu,\n", o.verify ? "true" : "false",
              (unsigned long long)verify_mismatches);
      fprintf(f, "  \"min_update_ms\": %lld,\n", (long long)o.min_update_ms);
      fprintf(f, "  \"budget_us\": %lld,\n  \"stream_us_max\": %.1f,\n  \"stream_us_p99\": %.1f,\n",
              (long long)o.budget_us, max_stream_us, Quantile(&stream_us, 0.99));
      fprintf(f, "  \"frames_over_budget\": %llu,\n  \"frames\": %zu,\n  \"most_primitives_in_a_frame\": %u,\n",
              (unsigned long long)frames_over_budget, stream_us.n, most_primitives_in_a_frame);
      fprintf(f,
              "  \"refining_frames\": %zu,\n  \"refining_frame_ms_median\": %.3f,\n  \"refining_frame_ms_p99\": %.3f,\n",
              refining_frames.n, Quantile(&refining_frames, 0.5), Quantile(&refining_frames, 0.99));
      fprintf(f, "  \"refining_frame_ms\": [");
      for (size_t i = 0; i < refining_frames.n; ++i) fprintf(f, "%s%.3f", i ? ", " : "", refining_frames.v[i]);
      fprintf(f, "],\n  \"refining_draw_ms\": [");
      for (size_t i = 0; i < refining_draw.n; ++i) fprintf(f, "%s%.3f", i ? ", " : "", refining_draw.v[i]);
      fprintf(f, "],\n  \"idle_frame_ms\": [");
      for (size_t i = 0; i < idle_frames.n; ++i) fprintf(f, "%s%.3f", i ? ", " : "", idle_frames.v[i]);
      fprintf(f, "],\n  \"stream_us\": [");
      for (size_t i = 0; i < stream_us.n; ++i) fprintf(f, "%s%.1f", i ? ", " : "", stream_us.v[i]);
      fprintf(f, "],\n");
      fprintf(f, "  \"idle_frames\": %zu,\n  \"idle_frame_ms_median\": %.3f,\n  \"idle_frame_ms_p99\": %.3f,\n",
              idle_frames.n, Quantile(&idle_frames, 0.5), Quantile(&idle_frames, 0.99));
      fprintf(f, "  \"time_to_base_ms\": %.2f,\n  \"time_to_full_ms\": %.2f,\n  \"predicted_vertices\": %llu,\n",
              s.time_to_base_ms, s.time_to_full_ms, (unsigned long long)s.predicted_vertices);
      fprintf(f, "  \"bytes_received\": %llu\n}\n", (unsigned long long)(s.reliable_bytes + s.unreliable_bytes));
      if (fclose(f) != 0) exit_code = 1;
    }
  }

  for (uint32_t i = 0; i < primitive_count; ++i) vw_primitive_free(&primitives[i]);
  free(primitives);
  free(levels);
  free(rgb);
  free(refining_frames.v);
  free(refining_draw.v);
  free(idle_frames.v);
  free(stream_us.v);
  vw_renderer_free(&renderer);
  ms_session_close(session);
  ms_client_destroy(client);
  glfwDestroyWindow(window);
  glfwTerminate();
  if (!complete && exit_code == 0) {
    fprintf(stderr, "meshstream_viewer: closed before the session completed\n");
  }
  return exit_code;
}
