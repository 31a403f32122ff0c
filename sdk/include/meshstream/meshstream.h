/* The C API of meshstream for engines: libmeshstream (docs/spec/c-api.md).
 *
 * A client is a connection to a meshstream server; a session streams one
 * asset version over it: the base mesh first, then one level of refinement
 * after another. The library decodes on a thread of its own as data
 * arrives; the host polls the session on its own thread and reads the
 * meshes of each event (levels decoded between two polls come as one
 * event for the highest); no callback ever runs on an internal thread.
 *
 *   ms_client_config cc = {0};  cc.struct_size = sizeof cc;  cc.server = "127.0.0.1:7600";
 *   ms_client* client;          ms_client_create(&cc, &client);
 *   ms_session_config sc = {0}; sc.struct_size = sizeof sc;  sc.asset = "bunny"; sc.max_level = -1;
 *   ms_session* session;        ms_session_open(client, &sc, &session);
 *   for (;;) {
 *     ms_event e;
 *     if (ms_session_poll(session, 100, &e) != MS_OK) { puts(ms_last_error()); break; }
 *     if (e.type == MS_EVENT_BASE_READY || e.type == MS_EVENT_LEVEL_READY) { ... ms_session_mesh ... }
 *     if (e.type == MS_EVENT_COMPLETE) break;
 *   }
 *   ms_session_close(session);  ms_client_destroy(client);
 *
 * Errors. Every function that can fail returns an ms_status; MS_OK is 0.
 * Any other value comes with a one-line message in ms_last_error() (the
 * argument or the object that is wrong, e.g. "config->asset: must not be
 * NULL", or the server's reason). No function throws, aborts on bad input or
 * keeps a pointer it was given past its return, except where written below.
 *
 * Ownership. ms_client_create and ms_session_open hand out objects the
 * caller frees with ms_client_destroy and ms_session_close (both accept
 * NULL). Strings in a config are copied during the call. Pointers the
 * library returns (mesh views, ms_stats.transport) belong to the
 * session. A client may be destroyed while sessions opened on it are still
 * open: its connection lives until the last of them closes.
 *
 * Thread safety. A client may be shared by several threads (sessions opened
 * on it from different threads at once). A session is used from one thread
 * at a time; only ms_session_cancel and ms_session_set_view may be called
 * from another thread while it is in use. ms_last_error is per thread. ms_version and
 * ms_status_name may be called from any thread.
 *
 * Mesh views. ms_session_mesh fills a view whose arrays stay valid and
 * unchanged until the next ms_session_poll or ms_session_close of that
 * session, whichever comes first.
 *
 * Versioned structs. Every struct the caller passes in or out that may grow
 * starts with `size_t struct_size`: set it to sizeof the struct as your
 * header declares it, and zero the struct before filling it. The library
 * reads (and writes) only the fields that fit inside struct_size, so a
 * program built against an older header keeps working; a field it does not
 * know is taken as zero, and zero always means the default. A struct_size
 * smaller than the first version of the struct (MS_*_V0_SIZE below) is
 * MS_ERR_INVALID_ARGUMENT. ms_event and ms_mesh_view are fixed forever;
 * what a mesh carries beyond them comes through functions of its own
 * (ms_session_mesh_colors).
 *
 * Pure C99; the only headers it includes are <stddef.h> and <stdint.h>.
 */
#ifndef MESHSTREAM_MESHSTREAM_H_
#define MESHSTREAM_MESHSTREAM_H_

#include <stddef.h>
#include <stdint.h>

#if defined(__GNUC__) || defined(__clang__)
#define MS_API __attribute__((visibility("default")))
#else
#define MS_API
#endif

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ms_client ms_client;
typedef struct ms_session ms_session;

/* Outcomes. The values are fixed; no new value will be added. */
typedef enum {
  MS_OK = 0,
  MS_ERR_INVALID_ARGUMENT, /* a bad argument, a call not valid in this state, or data that is not valid */
  MS_ERR_NOT_FOUND,        /* the asset or version does not exist (for this token) */
  MS_ERR_UNAUTHENTICATED,  /* no token, a token that is not valid, or one that may not do this */
  MS_ERR_UNAVAILABLE,      /* the server cannot be reached, is busy, or ended the session early; retry */
  MS_ERR_TIMEOUT,          /* a deadline ran out: ms_client_config.deadline_ms, or the server's own */
  MS_ERR_INTERNAL          /* anything else: a file that cannot be written, damaged data, a bug */
} ms_status;

typedef struct {
  size_t struct_size;      /* sizeof(ms_client_config) */
  const char* server;      /* HOST:PORT; NULL: "127.0.0.1:7600" */
  const char* token;       /* sent as "authorization: Bearer TOKEN"; NULL or "": none */
  /* Added beside the first version (MS_CLIENT_CONFIG_V0_SIZE ends above). */
  int32_t tls;             /* non-zero: TLS (also implied by tls_ca_pem) */
  const char* tls_ca_pem;  /* PEM text of the roots that sign the server's certificate; NULL: the system's */
  int64_t deadline_ms;     /* each session must end within this many ms of ms_session_open; 0: no deadline.
                            * One that does not fails with MS_ERR_TIMEOUT (from open or a poll). */
} ms_client_config;
#define MS_CLIENT_CONFIG_V0_SIZE (offsetof(ms_client_config, token) + sizeof(const char*))

/* What the viewer sees (docs/spec/streaming-protocol.md, "Views"): the server
 * sends first the refinements whose error spans the most pixels of it, the
 * primitives and spatial parts outside its frustum last. */
typedef struct {
  double camera_position[3];   /* the eye, in the asset's scene units */
  double view_projection[16];  /* column-major (glTF, OpenGL): clip = M (x, y, z, 1) */
  uint32_t viewport_width;     /* pixels, 1..65536 */
  uint32_t viewport_height;
} ms_view;

typedef struct {
  size_t struct_size;      /* sizeof(ms_session_config) */
  const char* asset;       /* required */
  int64_t version;         /* 0: the latest READY version */
  int32_t max_level;       /* the scene's level to stop at (its refinements with one primitive); -1: all (0: the base only) */
  int32_t tcp_only;        /* non-zero: the datagrams travel over the gRPC stream */
  /* Beyond the first version (read only when struct_size covers them; 0 / NULL: none): */
  uint64_t byte_budget;    /* stop after this many bytes on both channels, COMPLETE at the level reached */
  int64_t time_budget_ms;  /* stop this long after open, COMPLETE at the level reached */
  const char* udp_via;     /* "HOST:PORT": send the UDP half there (a relay, a tunnel) instead of the advertised endpoint */
  int32_t repair;          /* non-zero: once the stream has ended, ask once for the lost datagrams and decode again:
                              the last LEVEL_READY shows the predicted mesh, COMPLETE the exact one (docs/spec/c-api.md) */
  int32_t decode_threads;  /* threads that decode a refinement whose datagrams all arrived (same output bit for bit):
                              0 or 1 the session's own thread, N > 1 a pool of N, -1 one per core; at most 64 */
  int32_t no_parity;       /* non-zero: no parity datagrams; what UDP loses is predicted (or repaired), never rebuilt */
  int32_t profile;         /* MS_PROFILE_*: which stream of the asset (docs/spec/c-api.md); 0: the server's choice */
  const ms_view* view;     /* the view at the start (copied); NULL: the scene's order by error */
} ms_session_config;

/* ms_session_config.profile (docs/spec/streaming-protocol.md, "Profiles"). */
#define MS_PROFILE_AUTO 0           /* the reliable profile over the stream alone, the loss-tolerant one over UDP */
#define MS_PROFILE_RELIABLE 1       /* smaller and faster to decode; no datagrams: the session uses the stream alone */
#define MS_PROFILE_LOSS_TOLERANT 2  /* datagrams that decode on their own, over any transport */
#define MS_SESSION_CONFIG_V0_SIZE (offsetof(ms_session_config, tcp_only) + sizeof(int32_t))

typedef enum {
  MS_EVENT_NONE = 0,       /* nothing happened within the timeout */
  MS_EVENT_BASE_READY,     /* every primitive's base mesh is decoded; level 0 */
  MS_EVENT_LEVEL_READY,    /* every primitive is refined to `level` (or has all it has) */
  MS_EVENT_COMPLETE,       /* the session is over; the meshes are final at `level` */
  MS_EVENT_ERROR           /* the session is over; `status` and ms_last_error say why */
} ms_event_type;

typedef struct {
  ms_event_type type;
  int32_t level;           /* BASE_READY: 0; LEVEL_READY, COMPLETE: the level every primitive shows */
  ms_status status;        /* MS_OK except for MS_EVENT_ERROR */
} ms_event;

/* One primitive's current mesh: indexed triangles, arrays tightly packed,
 * one entry per vertex. Valid until the next ms_session_poll or close. */
typedef struct {
  size_t vertex_count;
  const float* positions;  /* xyz per vertex */
  const float* normals;    /* xyz per vertex, or NULL */
  const float* texcoords;  /* uv per vertex (TEXCOORD_0), or NULL */
  size_t index_count;      /* three per triangle */
  const uint32_t* indices;
  const uint8_t* predicted; /* 1 per vertex: 1 where its position may differ from the loss-free decode (predicted after a loss, or placed relative to a predicted one), 0 exact */
} ms_mesh_view;

/* What ms_session_stats reports (the struct has its own name because C has
 * one namespace for functions and typedefs). */
typedef struct {
  size_t struct_size;           /* sizeof(ms_stats); set by the caller */
  uint64_t reliable_bytes;      /* headers, base meshes, control blocks */
  uint64_t unreliable_bytes;    /* datagram payloads */
  uint64_t datagrams_received;
  uint64_t datagrams_rejected;  /* malformed or not fitting their stream */
  double time_to_base_ms;       /* from open to BASE_READY; 0 before */
  double time_to_full_ms;       /* from open to COMPLETE; 0 before */
  const char* transport;        /* "grpc", "udp", or "" before BASE_READY; valid until the next poll or close */
  uint64_t predicted_vertices;  /* vertices whose position may differ from the loss-free decode, over all primitives */
  int32_t levels;               /* the most refinements any primitive has in this session */
  int32_t level_shown;          /* the level every primitive has reached; -1 before BASE_READY */
  uint32_t primitive_count;
  /* Beyond the first version (written only when struct_size covers them): */
  uint64_t datagrams_lost;      /* data datagrams sent and never received: predicted instead */
  uint64_t datagrams_duplicate; /* copies, and datagrams that came too late */
  double hello_rtt_ms;          /* the UDP HELLO round trip; 0 without UDP */
  uint64_t repaired_datagrams;  /* datagrams the repair brought (config->repair) */
  double time_to_exact_ms;      /* from open to the exact mesh; 0 while the mesh is predicted */
  uint64_t reliable_datagram_bytes; /* datagram bytes the server sent on the gRPC stream (its reliable cut) over UDP */
  uint64_t early_datagram_bytes; /* ... and before the UDP address was proven (no wait for the HELLO) */
  uint64_t datagrams_late;      /* UDP datagrams that came after their refinement was decoded without them */
  uint32_t losses_declared;     /* UDP refinements decoded once later packet numbers showed their loss */
  double decode_after_last_byte_ms; /* at COMPLETE: from the last arrival to the full mesh (the decoding left) */
  uint64_t parallel_splits;     /* splits decoded on the config's decode_threads (0 with one thread) */
  uint64_t datagrams_recovered; /* data datagrams parity datagrams rebuilt (of datagrams_lost: no round trip) */
  uint64_t parity_datagrams;    /* parity datagrams received */
  int32_t profile;              /* MS_PROFILE_RELIABLE or MS_PROFILE_LOSS_TOLERANT once started; 0 before */
} ms_stats;
#define MS_STATS_V0_SIZE (offsetof(ms_stats, primitive_count) + sizeof(uint32_t))

/* Clients. Creating one does not connect yet: a server that cannot be
 * reached shows as MS_ERR_UNAVAILABLE from ms_session_open or its first
 * poll. */
MS_API ms_status ms_client_create(const ms_client_config* config, ms_client** out);
MS_API void ms_client_destroy(ms_client* client);

/* Sessions. An asset that does not exist, or a token that may not read it,
 * is reported by the first poll that hears from the server (MS_EVENT_ERROR
 * with MS_ERR_NOT_FOUND or MS_ERR_UNAUTHENTICATED). */
MS_API ms_status ms_session_open(ms_client* client, const ms_session_config* config, ms_session** out);

/* Processes what arrived, waiting at most timeout_ms (0: not at all) for
 * something, and writes the next event to *out. Returns the event's status:
 * MS_OK for MS_EVENT_NONE (the time ran out: not an error), BASE_READY,
 * LEVEL_READY and COMPLETE; for MS_EVENT_ERROR the error's status, with its
 * message in ms_last_error. After COMPLETE or ERROR it returns MS_EVENT_NONE
 * at once. A NULL argument is MS_ERR_INVALID_ARGUMENT (*out, if given, is
 * then MS_EVENT_NONE). Invalidates the session's mesh views. */
MS_API ms_status ms_session_poll(ms_session* session, int32_t timeout_ms, ms_event* out);

/* The primitives the session refines (0 before BASE_READY, or for NULL). */
MS_API uint32_t ms_session_primitive_count(const ms_session* session);

/* The current mesh of a primitive (0 .. primitive_count - 1). Valid until
 * the next poll or close; asking again before then gives the same arrays. */
MS_API ms_status ms_session_mesh(ms_session* session, uint32_t primitive, ms_mesh_view* out);

/* The primitive's vertex colours (COLOR_0, linear RGBA, 4 floats per
 * vertex), or *out_rgba = NULL when it has none. Same lifetime as a view. */
MS_API ms_status ms_session_mesh_colors(ms_session* session, uint32_t primitive, const float** out_rgba);

/* A run of elements: [first, first + count). */
typedef struct {
  uint32_t first;
  uint32_t count;
} ms_range;

/* What changed in a primitive's view since the host last read it: the ranges
 * a renderer uploads to its GPU buffers instead of the whole mesh
 * (docs/spec/c-api.md, "Changes"; docs/engine-integration.md). A read is a
 * call of ms_session_mesh or ms_session_mesh_changes for the primitive after
 * a poll; the changes compare the view of this poll with the view the read
 * before showed (on an earlier poll), so a host that skips a primitive for
 * some polls gets everything that changed meanwhile. Asking again before the
 * next poll gives the same answer. A level appends vertices and triangles and
 * changes others scattered over the mesh (each split moves the vertex it
 * splits and renumbers one index of some of its triangles).
 * Write every vertex range of every array (positions, normals, texcoords,
 * colours, predicted) before drawing with the index ranges. The pointers
 * stay valid until the next poll or close. */
typedef struct {
  size_t struct_size;            /* sizeof(ms_mesh_changes); set by the caller */
  uint32_t max_ranges;           /* set by the caller: at most this many ranges of each kind, the nearest merged
                                    first (their gaps then count as changed); 0: no limit */
  int32_t everything;            /* non-zero: no read before to compare with: the ranges cover the whole view */
  const ms_range* vertex_ranges; /* vertices whose position, normal, texcoord, colour or predicted flag changed,
                                    or that are new: ascending, disjoint */
  uint32_t vertex_range_count;
  const ms_range* index_ranges;  /* indices that changed or are new (a split renumbers single indices) */
  uint32_t index_range_count;
  uint64_t changed_vertices;     /* what the ranges cover */
  uint64_t changed_indices;
  uint64_t previous_vertex_count; /* of the view compared with (0 with everything); the view's own counts are */
  uint64_t previous_index_count;  /* in ms_mesh_view: a count may also shrink (a decode again), never in a level */
} ms_mesh_changes;
#define MS_MESH_CHANGES_V0_SIZE (offsetof(ms_mesh_changes, previous_index_count) + sizeof(uint64_t))

/* Fills *out (its struct_size and max_ranges set by the caller) with the
 * ranges of the primitive's view (the one ms_session_mesh gives now) that
 * differ from the view of the read before. */
MS_API ms_status ms_session_mesh_changes(ms_session* session, uint32_t primitive, ms_mesh_changes* out);

/* Where the primitive sits in the asset's glTF: its mesh and its index
 * among that mesh's primitives. */
MS_API ms_status ms_session_gltf_position(const ms_session* session, uint32_t primitive, uint32_t* mesh,
                                          uint32_t* mesh_primitive);

/* Where the primitive is drawn: *out_matrices points to *out_count world
 * matrices (16 floats each, column-major as glTF and OpenGL: world =
 * M (x, y, z, 1)), one per node instance of its glTF mesh reached from the
 * asset's default scene; one identity from a server that sends no scene; 0
 * when no node shows it. Same lifetime as a view (the next poll or close). */
MS_API ms_status ms_session_instances(ms_session* session, uint32_t primitive, const float** out_matrices,
                                      uint32_t* out_count);

/* The session's counters and state; writes the fields that fit in
 * out->struct_size. */
MS_API ms_status ms_session_stats(const ms_session* session, ms_stats* out);

/* The current scene written as .glb or .gltf (by the extension of path): the
 * asset's scene as the server sent it (nodes, materials, textures, skins,
 * animations, carried primitives) with every refined primitive at the level
 * it has reached. From a server that sends no scene: one glTF mesh per mesh
 * of the refined primitives, no materials. Before BASE_READY it is
 * MS_ERR_INVALID_ARGUMENT. */
MS_API ms_status ms_session_export(ms_session* session, const char* path);

/* Stops the session: the server frees it and the next poll returns
 * MS_EVENT_ERROR with MS_ERR_UNAVAILABLE ("CANCELLED: ..."), unless the session
 * was already over. May be called from another thread. */
MS_API ms_status ms_session_cancel(ms_session* session);

/* The viewer's view changed (copied): the server orders what it has not begun
 * by it, at most once a second (the latest wins). From the session's thread
 * or any other; MS_ERR_INVALID_ARGUMENT names a bad field. */
MS_API ms_status ms_session_set_view(ms_session* session, const ms_view* view);

MS_API void ms_session_close(ms_session* session);

/* This thread's last error: the message of the last call on this thread
 * that returned something other than MS_OK, "" after a call that returned
 * MS_OK. It starts with the SDK's code ("NOT_FOUND: asset bunny does not
 * exist") except for the argument checks of this API. The functions that
 * return no ms_status leave it alone, except ms_session_primitive_count(NULL),
 * which sets it. Never NULL; valid until the next ms_* call on this thread. */
MS_API const char* ms_last_error(void);

/* The library's version, "MAJOR.MINOR.PATCH" (the project's version). */
MS_API const char* ms_version(void);

/* "MS_OK", "MS_ERR_NOT_FOUND", ...; "MS_ERR_UNKNOWN" for a value not in ms_status. */
MS_API const char* ms_status_name(ms_status status);

#ifdef __cplusplus
}  /* extern "C" */
#endif

#endif /* MESHSTREAM_MESHSTREAM_H_ */
