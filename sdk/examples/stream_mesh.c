/* stream_mesh: the C API of meshstream (docs/spec/c-api.md) from end to end.
 *
 *   stream_mesh SERVER ASSET OUT.glb [--tcp-only] [--token T]
 *
 * Opens a client and a session, polls to the end printing one line per
 * level ("level K: V vertices, F faces, P predicted, T ms", summed over the
 * primitives from their mesh views), writes the meshes reached to OUT.glb
 * (or .gltf) and prints a last line. The token also comes from the
 * environment variable MESHSTREAM_TOKEN (--token wins).
 * Exit codes: 0 done, 1 the session or the export failed, 2 usage.
 *
 * Build it against an installed libmeshstream with
 *   cc -std=c99 stream_mesh.c $(pkg-config --cflags --libs meshstream)
 */
#define _POSIX_C_SOURCE 200809L

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <meshstream/meshstream.h>

#define POLL_TIMEOUT_MS 30000

static double now_ms(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (double)t.tv_sec * 1e3 + (double)t.tv_nsec / 1e6;
}

static int usage(FILE* to, int code) {
  fprintf(to,
          "usage: stream_mesh SERVER ASSET OUT.glb [--tcp-only] [--token T]\n"
          "  SERVER      HOST:PORT of a meshstream server\n"
          "  ASSET       the asset to stream (its latest READY version)\n"
          "  OUT.glb     where the meshes reached are written (.glb or .gltf)\n"
          "  --tcp-only  the datagrams travel over the gRPC stream\n"
          "  --token T   API token (default: $MESHSTREAM_TOKEN)\n");
  return code;
}

/* The totals of one moment of the session, over its primitives. */
typedef struct {
  size_t vertices, faces, predicted;
} totals;

static ms_status sum_meshes(ms_session* session, totals* out) {
  uint32_t count = ms_session_primitive_count(session);
  uint32_t i;
  out->vertices = out->faces = out->predicted = 0;
  for (i = 0; i < count; ++i) {
    ms_mesh_view view;
    size_t v;
    ms_status status = ms_session_mesh(session, i, &view);
    if (status != MS_OK) return status;
    out->vertices += view.vertex_count;
    out->faces += view.index_count / 3;
    for (v = 0; v < view.vertex_count; ++v) out->predicted += view.predicted[v];
  }
  return MS_OK;
}

static int fail(const char* what, ms_status status) {
  fprintf(stderr, "stream_mesh: %s: %s (%s)\n", what, ms_last_error(), ms_status_name(status));
  return 1;
}

int main(int argc, char** argv) {
  const char* positional[3];
  int positionals = 0;
  const char* token = getenv("MESHSTREAM_TOKEN");
  int tcp_only = 0;
  int i;
  int code = 1;
  ms_client_config client_config;
  ms_session_config session_config;
  ms_client* client = NULL;
  ms_session* session = NULL;
  ms_status status;
  double start;

  for (i = 1; i < argc; ++i) {
    const char* a = argv[i];
    if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) return usage(stdout, 0);
    if (strcmp(a, "--tcp-only") == 0) {
      tcp_only = 1;
    } else if (strcmp(a, "--token") == 0) {
      if (i + 1 >= argc) {
        fprintf(stderr, "stream_mesh: --token needs a value\n");
        return usage(stderr, 2);
      }
      token = argv[++i];
    } else if (a[0] == '-' && a[1] == '-') {
      fprintf(stderr, "stream_mesh: unknown option %s\n", a);
      return usage(stderr, 2);
    } else if (positionals < 3) {
      positional[positionals++] = a;
    } else {
      fprintf(stderr, "stream_mesh: one argument too many: %s\n", a);
      return usage(stderr, 2);
    }
  }
  if (positionals != 3) return usage(stderr, 2);

  memset(&client_config, 0, sizeof client_config);
  client_config.struct_size = sizeof client_config;
  client_config.server = positional[0];
  client_config.token = token;
  status = ms_client_create(&client_config, &client);
  if (status != MS_OK) return fail("client", status);

  memset(&session_config, 0, sizeof session_config);
  session_config.struct_size = sizeof session_config;
  session_config.asset = positional[1];
  session_config.version = 0;
  session_config.max_level = -1;
  session_config.tcp_only = tcp_only;
  start = now_ms();
  status = ms_session_open(client, &session_config, &session);
  if (status != MS_OK) {
    code = fail("session", status);
    goto done;
  }

  for (;;) {
    ms_event event;
    totals t;
    status = ms_session_poll(session, POLL_TIMEOUT_MS, &event);
    if (status != MS_OK) {
      code = fail("session", status);
      goto done;
    }
    if (event.type == MS_EVENT_NONE) {
      fprintf(stderr, "stream_mesh: session: nothing arrived for %d s\n", POLL_TIMEOUT_MS / 1000);
      goto done;
    }
    if (event.type == MS_EVENT_COMPLETE) break;
    /* BASE_READY is level 0; LEVEL_READY the highest level decoded since the last poll. */
    status = sum_meshes(session, &t);
    if (status != MS_OK) {
      code = fail("mesh", status);
      goto done;
    }
    printf("level %d: %zu vertices, %zu faces, %zu predicted, %.0f ms\n", (int)event.level, t.vertices, t.faces,
           t.predicted, now_ms() - start);
    fflush(stdout);
  }

  status = ms_session_export(session, positional[2]);
  if (status != MS_OK) {
    code = fail("export", status);
    goto done;
  }
  {
    ms_stats stats;
    totals t;
    memset(&stats, 0, sizeof stats);
    stats.struct_size = sizeof stats;
    status = ms_session_stats(session, &stats);
    if (status == MS_OK) status = sum_meshes(session, &t);
    if (status != MS_OK) {
      code = fail("stats", status);
      goto done;
    }
    printf("complete: level %d of %d, %zu vertices, %zu faces, %u primitives, transport %s, %.0f ms; wrote %s\n",
           (int)stats.level_shown, (int)stats.levels, t.vertices, t.faces, (unsigned)stats.primitive_count,
           stats.transport, stats.time_to_full_ms, positional[2]);
  }
  code = 0;

done:
  ms_session_close(session);
  ms_client_destroy(client);
  return code;
}
