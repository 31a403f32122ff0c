// The C API (sdk/include/meshstream/meshstream.h, docs/spec/c-api.md): a thin
// translation onto sdk::Client and sdk::Session. What this file adds is only
// what C needs: argument checks, the struct_size rule, Status -> ms_status,
// the thread's last error, no exception across the boundary, and buffers
// that keep a mesh view alive until the next poll.
#include "meshstream/meshstream.h"

#include <cstring>
#include <exception>
#include <memory>
#include <new>
#include <string>
#include <utility>
#include <vector>

#include "codec/core/status.h"
#include "sdk/client.h"
#include "sdk/mesh_changes.h"
#include "sdk/session.h"

#ifndef MESHSTREAM_VERSION
#error "MESHSTREAM_VERSION must be defined by the build (the project's version)"
#endif

struct ms_client {
  std::shared_ptr<meshstream::sdk::Client> client;
};

struct ms_session {
  // Declared before `session`, so destroyed after it: the session's channel
  // stays alive even when ms_client_destroy came first.
  std::shared_ptr<meshstream::sdk::Client> client;
  std::unique_ptr<meshstream::sdk::Session> session;
  uint64_t generation = 1;  // bumped by every poll; a view is valid within one generation
  // A primitive's view: the arrays the host reads, updated in place by the
  // ranges that changed since the read before (sdk/mesh_changes.h), which
  // ms_session_mesh_changes hands out.
  struct View {
    uint64_t generation = 0;  // 0: never filled
    std::vector<float> positions, normals, texcoords, colors;
    std::vector<uint32_t> indices;
    meshstream::sdk::MeshChanges changes;  // also keeps the predicted flags
    std::vector<ms_range> vertex_ranges, index_ranges;  // ms_session_mesh_changes's, after its max_ranges
    std::vector<float> instances;  // ms_session_instances's matrices (the scene does not change)
    bool has_instances = false;
  };
  std::vector<View> views;
  mutable std::string transport;  // what ms_stats.transport points to
};

namespace {

using meshstream::Status;
using meshstream::StatusCode;

thread_local std::string last_error;

ms_status Ok() {
  last_error.clear();
  return MS_OK;
}

ms_status Fail(ms_status status, std::string message) {
  last_error = std::move(message);
  return status;
}

ms_status ToC(StatusCode code) {
  switch (code) {
    case StatusCode::kOk: return MS_OK;
    case StatusCode::kInvalidArgument:
    case StatusCode::kInvalidInput:
    case StatusCode::kFailedPrecondition: return MS_ERR_INVALID_ARGUMENT;
    case StatusCode::kNotFound: return MS_ERR_NOT_FOUND;
    case StatusCode::kUnauthenticated:
    case StatusCode::kPermissionDenied: return MS_ERR_UNAUTHENTICATED;
    case StatusCode::kUnavailable:
    case StatusCode::kResourceExhausted:
    case StatusCode::kAborted:
    case StatusCode::kCancelled: return MS_ERR_UNAVAILABLE;
    case StatusCode::kDeadlineExceeded: return MS_ERR_TIMEOUT;
    default: return MS_ERR_INTERNAL;
  }
}

ms_status Fail(const Status& status) { return Fail(ToC(status.code()), status.ToString()); }

ms_status Null(const char* what) { return Fail(MS_ERR_INVALID_ARGUMENT, std::string(what) + ": must not be NULL"); }

meshstream::View ToView(const ms_view& v) {
  meshstream::View out;
  for (int a = 0; a < 3; ++a) out.camera[a] = v.camera_position[a];
  for (int i = 0; i < 16; ++i) out.view_projection[i] = v.view_projection[i];
  out.viewport_width = v.viewport_width;
  out.viewport_height = v.viewport_height;
  return out;
}

// The message of an exception caught at the boundary; building it may fail
// too (no memory), and then the message is empty rather than a throw.
ms_status FailNoThrow(ms_status status, const char* function, const char* what) noexcept {
  try {
    last_error = std::string(function) + ": " + what;
  } catch (...) {
    last_error.clear();
  }
  return status;
}

// Runs `body`, turning any exception into MS_ERR_INTERNAL.
template <typename F>
ms_status Guard(const char* function, F&& body) noexcept {
  try {
    return body();
  } catch (const std::bad_alloc&) {
    return FailNoThrow(MS_ERR_INTERNAL, function, "out of memory");
  } catch (const std::exception& e) {
    return FailNoThrow(MS_ERR_INTERNAL, function, e.what());
  } catch (...) {
    return FailNoThrow(MS_ERR_INTERNAL, function, "an unknown exception");
  }
}

// The struct_size rule: at least the first version, and a field is read
// only when it fits entirely.
ms_status CheckSize(size_t struct_size, size_t v0, const char* what) {
  if (struct_size >= v0) return MS_OK;
  return Fail(MS_ERR_INVALID_ARGUMENT, std::string(what) + "->struct_size: " + std::to_string(struct_size) +
                                           " is smaller than the first version of the struct (" +
                                           std::to_string(v0) + " bytes); set it to sizeof the struct");
}

bool Fits(size_t struct_size, size_t offset, size_t size) { return offset + size <= struct_size; }

#define MS_FIELD_FITS(object, type, field) Fits((object)->struct_size, offsetof(type, field), sizeof((object)->field))

ms_event_type ToC(meshstream::sdk::EventType type) {
  switch (type) {
    case meshstream::sdk::EventType::kBaseReady: return MS_EVENT_BASE_READY;
    case meshstream::sdk::EventType::kLevelReady: return MS_EVENT_LEVEL_READY;
    case meshstream::sdk::EventType::kComplete: return MS_EVENT_COMPLETE;
    case meshstream::sdk::EventType::kError: return MS_EVENT_ERROR;
    default: return MS_EVENT_NONE;
  }
}

ms_status CheckPrimitive(const ms_session* session, uint32_t primitive) {
  const size_t count = session->session->primitive_count();
  if (primitive < count) return MS_OK;
  return Fail(MS_ERR_INVALID_ARGUMENT, "primitive: " + std::to_string(primitive) + " does not exist (the session has " +
                                           std::to_string(count) + " primitives now)");
}

// A primitive's view state (the primitive checked by the caller).
ms_session::View& ViewOf(ms_session* session, uint32_t primitive) {
  if (session->views.size() < session->session->primitive_count()) {
    session->views.resize(session->session->primitive_count());
  }
  return session->views[primitive];
}

// The view buffers of a primitive, brought up to date once per poll
// generation: only the vertices and triangles that changed since the last
// fill are written (all of them the first time).
ms_status Fill(ms_session* session, uint32_t primitive, ms_session::View** out) {
  ms_session::View& view = ViewOf(session, primitive);
  if (view.generation != session->generation) {
    auto shown = session->session->Quantized(primitive);
    if (!shown.ok()) return Fail(shown.status());
    const meshstream::QuantizedMesh& mesh = *shown->mesh;
    view.changes.Update(mesh, *shown->exact);
    const size_t n = mesh.vertex_count();
    const meshstream::AttributeLayout& layout = mesh.layout;
    view.positions.resize(3 * n);
    view.normals.resize(layout.has_normals ? 3 * n : 0);
    view.texcoords.resize(layout.texcoord_sets > 0 ? 2 * n : 0);
    view.colors.resize(layout.has_colors ? 4 * n : 0);
    meshstream::FlatVertexArrays arrays;
    arrays.positions = view.positions.data();
    arrays.normals = layout.has_normals ? view.normals.data() : nullptr;
    arrays.texcoords = layout.texcoord_sets > 0 ? view.texcoords.data() : nullptr;
    arrays.colors = layout.has_colors ? view.colors.data() : nullptr;
    for (const meshstream::sdk::Range& r : view.changes.vertices()) {
      meshstream::DequantizeVerticesInto(mesh, r.first, r.count, arrays);
    }
    view.indices.resize(mesh.indices.size());
    for (const meshstream::sdk::Range& r : view.changes.indices()) {
      std::memcpy(view.indices.data() + r.first, mesh.indices.data() + r.first, size_t{r.count} * sizeof(uint32_t));
    }
    view.generation = session->generation;
  }
  *out = &view;
  return MS_OK;
}

template <typename T>
const T* DataOrNull(const std::vector<T>& v) {
  return v.empty() ? nullptr : v.data();
}

}  // namespace

extern "C" {

ms_status ms_client_create(const ms_client_config* config, ms_client** out) {
  return Guard("ms_client_create", [&] {
    if (out != nullptr) *out = nullptr;
    if (config == nullptr) return Null("config");
    if (out == nullptr) return Null("out");
    if (CheckSize(config->struct_size, MS_CLIENT_CONFIG_V0_SIZE, "config") != MS_OK) return MS_ERR_INVALID_ARGUMENT;
    meshstream::sdk::ClientOptions options;
    if (config->server != nullptr) options.server = config->server;
    if (config->token != nullptr) options.token = config->token;
    if (MS_FIELD_FITS(config, ms_client_config, tls)) options.tls = config->tls != 0;
    if (MS_FIELD_FITS(config, ms_client_config, tls_ca_pem) && config->tls_ca_pem != nullptr) {
      options.tls_ca_pem = config->tls_ca_pem;
    }
    if (MS_FIELD_FITS(config, ms_client_config, deadline_ms)) {
      if (config->deadline_ms < 0) return Fail(MS_ERR_INVALID_ARGUMENT, "config->deadline_ms: not negative (0: none)");
      options.session_deadline_ms = config->deadline_ms;
    }
    auto client = meshstream::sdk::Client::Create(options);
    if (!client.ok()) return Fail(client.status());
    auto handle = std::make_unique<ms_client>();
    handle->client = std::shared_ptr<meshstream::sdk::Client>(std::move(client).value());
    *out = handle.release();
    return Ok();
  });
}

void ms_client_destroy(ms_client* client) { delete client; }

ms_status ms_session_open(ms_client* client, const ms_session_config* config, ms_session** out) {
  return Guard("ms_session_open", [&] {
    if (out != nullptr) *out = nullptr;
    if (client == nullptr) return Null("client");
    if (config == nullptr) return Null("config");
    if (out == nullptr) return Null("out");
    if (CheckSize(config->struct_size, MS_SESSION_CONFIG_V0_SIZE, "config") != MS_OK) return MS_ERR_INVALID_ARGUMENT;
    if (config->asset == nullptr) return Null("config->asset");
    meshstream::sdk::SessionOptions options;
    options.asset = config->asset;
    options.version = config->version;
    options.max_level = config->max_level;
    options.tcp_only = config->tcp_only != 0;
    if (MS_FIELD_FITS(config, ms_session_config, byte_budget)) options.byte_budget = config->byte_budget;
    if (MS_FIELD_FITS(config, ms_session_config, time_budget_ms)) {
      if (config->time_budget_ms < 0) return Fail(MS_ERR_INVALID_ARGUMENT, "config->time_budget_ms: not negative (0: none)");
      options.time_budget_ms = config->time_budget_ms;
    }
    if (MS_FIELD_FITS(config, ms_session_config, udp_via) && config->udp_via != nullptr) options.udp_via = config->udp_via;
    if (MS_FIELD_FITS(config, ms_session_config, repair)) options.repair = config->repair != 0;
    if (MS_FIELD_FITS(config, ms_session_config, decode_threads)) options.decode_threads = config->decode_threads;
    if (MS_FIELD_FITS(config, ms_session_config, no_parity)) options.no_parity = config->no_parity != 0;
    if (MS_FIELD_FITS(config, ms_session_config, profile)) {
      if (config->profile < MS_PROFILE_AUTO || config->profile > MS_PROFILE_LOSS_TOLERANT) {
        return Fail(MS_ERR_INVALID_ARGUMENT, "config->profile: MS_PROFILE_AUTO, MS_PROFILE_RELIABLE or MS_PROFILE_LOSS_TOLERANT");
      }
      options.profile = static_cast<meshstream::sdk::SessionOptions::Profile>(config->profile);
    }
    if (MS_FIELD_FITS(config, ms_session_config, view) && config->view != nullptr) options.view = ToView(*config->view);
    auto session = meshstream::sdk::Session::Open(*client->client, options);
    if (!session.ok()) return Fail(session.status());
    auto handle = std::make_unique<ms_session>();
    handle->client = client->client;
    handle->session = std::move(session).value();
    *out = handle.release();
    return Ok();
  });
}

ms_status ms_session_poll(ms_session* session, int32_t timeout_ms, ms_event* out) {
  return Guard("ms_session_poll", [&] {
    if (out != nullptr) *out = ms_event{MS_EVENT_NONE, 0, MS_ERR_INVALID_ARGUMENT};
    if (session == nullptr) return Null("session");
    if (out == nullptr) return Null("out");
    ++session->generation;  // the views of the last poll end here, whatever happens next
    const meshstream::sdk::Event e = session->session->Poll(timeout_ms);
    out->type = ToC(e.type);
    out->level = e.level;
    out->status = MS_OK;
    if (e.type == meshstream::sdk::EventType::kError) {
      out->status = ToC(e.status.code());
      if (out->status == MS_OK) out->status = MS_ERR_INTERNAL;  // an error event always carries an error
      return Fail(out->status, e.status.ToString());
    }
    return Ok();
  });
}

uint32_t ms_session_primitive_count(const ms_session* session) {
  if (session == nullptr) {
    Guard("ms_session_primitive_count", [] { return Null("session"); });
    return 0;
  }
  return static_cast<uint32_t>(session->session->primitive_count());
}

ms_status ms_session_mesh(ms_session* session, uint32_t primitive, ms_mesh_view* out) {
  return Guard("ms_session_mesh", [&] {
    if (session == nullptr) return Null("session");
    if (out == nullptr) return Null("out");
    *out = ms_mesh_view{};
    if (CheckPrimitive(session, primitive) != MS_OK) return MS_ERR_INVALID_ARGUMENT;
    ms_session::View* view = nullptr;
    const ms_status s = Fill(session, primitive, &view);
    if (s != MS_OK) return s;
    out->vertex_count = view->positions.size() / 3;
    out->positions = DataOrNull(view->positions);
    out->normals = DataOrNull(view->normals);
    out->texcoords = DataOrNull(view->texcoords);
    out->index_count = view->indices.size();
    out->indices = DataOrNull(view->indices);
    out->predicted = DataOrNull(view->changes.predicted());
    return Ok();
  });
}

ms_status ms_session_mesh_colors(ms_session* session, uint32_t primitive, const float** out_rgba) {
  return Guard("ms_session_mesh_colors", [&] {
    if (session == nullptr) return Null("session");
    if (out_rgba == nullptr) return Null("out_rgba");
    *out_rgba = nullptr;
    if (CheckPrimitive(session, primitive) != MS_OK) return MS_ERR_INVALID_ARGUMENT;
    ms_session::View* view = nullptr;
    const ms_status s = Fill(session, primitive, &view);
    if (s != MS_OK) return s;
    *out_rgba = DataOrNull(view->colors);
    return Ok();
  });
}

ms_status ms_session_mesh_changes(ms_session* session, uint32_t primitive, ms_mesh_changes* out) {
  return Guard("ms_session_mesh_changes", [&] {
    if (session == nullptr) return Null("session");
    if (out == nullptr) return Null("out");
    if (CheckSize(out->struct_size, MS_MESH_CHANGES_V0_SIZE, "out") != MS_OK) return MS_ERR_INVALID_ARGUMENT;
    const uint32_t max_ranges = out->max_ranges;
    const size_t struct_size = out->struct_size;
    if (CheckPrimitive(session, primitive) != MS_OK) return MS_ERR_INVALID_ARGUMENT;
    ms_session::View* view = nullptr;
    const ms_status s = Fill(session, primitive, &view);
    if (s != MS_OK) return s;
    const meshstream::sdk::MeshChanges& c = view->changes;
    std::vector<meshstream::sdk::Range> vertices = c.vertices();
    std::vector<meshstream::sdk::Range> indices = c.indices();
    meshstream::sdk::LimitRanges(vertices, max_ranges);
    meshstream::sdk::LimitRanges(indices, max_ranges);
    view->vertex_ranges.clear();
    for (const auto& r : vertices) view->vertex_ranges.push_back(ms_range{r.first, r.count});
    view->index_ranges.clear();
    for (const auto& r : indices) view->index_ranges.push_back(ms_range{r.first, r.count});
    std::memset(out, 0, sizeof(ms_mesh_changes) < struct_size ? sizeof(ms_mesh_changes) : struct_size);
    out->struct_size = struct_size;
    out->max_ranges = max_ranges;
    out->everything = c.everything() ? 1 : 0;
    out->vertex_ranges = DataOrNull(view->vertex_ranges);
    out->vertex_range_count = static_cast<uint32_t>(view->vertex_ranges.size());
    out->index_ranges = DataOrNull(view->index_ranges);
    out->index_range_count = static_cast<uint32_t>(view->index_ranges.size());
    out->changed_vertices = meshstream::sdk::RangeElements(vertices);
    out->changed_indices = meshstream::sdk::RangeElements(indices);
    out->previous_vertex_count = c.previous_vertex_count();
    out->previous_index_count = c.previous_index_count();
    return Ok();
  });
}

ms_status ms_session_instances(ms_session* session, uint32_t primitive, const float** out_matrices,
                               uint32_t* out_count) {
  return Guard("ms_session_instances", [&] {
    if (out_matrices != nullptr) *out_matrices = nullptr;
    if (out_count != nullptr) *out_count = 0;
    if (session == nullptr) return Null("session");
    if (out_matrices == nullptr) return Null("out_matrices");
    if (out_count == nullptr) return Null("out_count");
    if (CheckPrimitive(session, primitive) != MS_OK) return MS_ERR_INVALID_ARGUMENT;
    ms_session::View& view = ViewOf(session, primitive);
    if (!view.has_instances) {
      view.instances.clear();
      for (const auto& m : session->session->Instances(primitive)) {
        for (double x : m) view.instances.push_back(static_cast<float>(x));
      }
      view.has_instances = true;
    }
    *out_matrices = DataOrNull(view.instances);
    *out_count = static_cast<uint32_t>(view.instances.size() / 16);
    return Ok();
  });
}

ms_status ms_session_gltf_position(const ms_session* session, uint32_t primitive, uint32_t* mesh,
                                   uint32_t* mesh_primitive) {
  return Guard("ms_session_gltf_position", [&] {
    if (session == nullptr) return Null("session");
    if (mesh == nullptr) return Null("mesh");
    if (mesh_primitive == nullptr) return Null("mesh_primitive");
    if (CheckPrimitive(session, primitive) != MS_OK) return MS_ERR_INVALID_ARGUMENT;
    const auto [m, p] = session->session->GltfPosition(primitive);
    *mesh = m;
    *mesh_primitive = p;
    return Ok();
  });
}

ms_status ms_session_stats(const ms_session* session, ms_stats* out) {
  return Guard("ms_session_stats", [&] {
    if (session == nullptr) return Null("session");
    if (out == nullptr) return Null("out");
    if (CheckSize(out->struct_size, MS_STATS_V0_SIZE, "out") != MS_OK) return MS_ERR_INVALID_ARGUMENT;
    const meshstream::sdk::Session& s = *session->session;
    const meshstream::sdk::SessionStats& stats = s.stats();
    // Every field of the first version fits (checked above); later ones go
    // through MS_FIELD_FITS.
    out->reliable_bytes = stats.reliable_bytes;
    out->unreliable_bytes = stats.unreliable_bytes;
    out->datagrams_received = stats.datagrams_received;
    out->datagrams_rejected = stats.datagrams_rejected;
    out->time_to_base_ms = stats.time_to_base_ms;
    out->time_to_full_ms = stats.time_to_full_ms;
    // The string lives in the session; it changes only within a poll.
    session->transport = stats.transport;
    out->transport = session->transport.c_str();
    out->predicted_vertices = s.predicted_vertices();
    out->levels = s.levels();
    out->level_shown = s.level_shown();
    out->primitive_count = static_cast<uint32_t>(s.primitive_count());
    if (MS_FIELD_FITS(out, ms_stats, datagrams_lost)) out->datagrams_lost = stats.datagrams_lost;
    if (MS_FIELD_FITS(out, ms_stats, datagrams_duplicate)) out->datagrams_duplicate = stats.datagrams_duplicate;
    if (MS_FIELD_FITS(out, ms_stats, hello_rtt_ms)) out->hello_rtt_ms = stats.hello_rtt_ms;
    if (MS_FIELD_FITS(out, ms_stats, repaired_datagrams)) out->repaired_datagrams = stats.repaired_datagrams;
    if (MS_FIELD_FITS(out, ms_stats, time_to_exact_ms)) out->time_to_exact_ms = stats.time_to_exact_ms;
    if (MS_FIELD_FITS(out, ms_stats, reliable_datagram_bytes)) {
      out->reliable_datagram_bytes = stats.reliable_datagram_bytes;
    }
    if (MS_FIELD_FITS(out, ms_stats, early_datagram_bytes)) out->early_datagram_bytes = stats.early_datagram_bytes;
    if (MS_FIELD_FITS(out, ms_stats, datagrams_late)) out->datagrams_late = stats.datagrams_late;
    if (MS_FIELD_FITS(out, ms_stats, losses_declared)) out->losses_declared = stats.losses_declared;
    if (MS_FIELD_FITS(out, ms_stats, decode_after_last_byte_ms)) {
      out->decode_after_last_byte_ms = stats.decode_after_last_byte_ms;
    }
    if (MS_FIELD_FITS(out, ms_stats, parallel_splits)) out->parallel_splits = stats.parallel_splits;
    if (MS_FIELD_FITS(out, ms_stats, datagrams_recovered)) out->datagrams_recovered = stats.datagrams_recovered;
    if (MS_FIELD_FITS(out, ms_stats, parity_datagrams)) out->parity_datagrams = stats.parity_datagrams;
    if (MS_FIELD_FITS(out, ms_stats, profile)) {
      out->profile = stats.profile == "reliable"        ? MS_PROFILE_RELIABLE
                     : stats.profile == "loss-tolerant" ? MS_PROFILE_LOSS_TOLERANT
                                                        : MS_PROFILE_AUTO;
    }
    return Ok();
  });
}

ms_status ms_session_export(ms_session* session, const char* path) {
  return Guard("ms_session_export", [&] {
    if (session == nullptr) return Null("session");
    if (path == nullptr) return Null("path");
    const Status s = session->session->Export(path);
    if (!s.ok()) return Fail(s);
    return Ok();
  });
}

ms_status ms_session_set_view(ms_session* session, const ms_view* view) {
  return Guard("ms_session_set_view", [&] {
    if (session == nullptr) return Null("session");
    if (view == nullptr) return Null("view");
    const meshstream::Status s = session->session->SetView(ToView(*view));
    if (!s.ok()) return Fail(s);
    return Ok();
  });
}

ms_status ms_session_cancel(ms_session* session) {
  return Guard("ms_session_cancel", [&] {
    if (session == nullptr) return Null("session");
    session->session->Cancel();
    return Ok();
  });
}

void ms_session_close(ms_session* session) { delete session; }

const char* ms_last_error(void) { return last_error.c_str(); }

const char* ms_version(void) { return MESHSTREAM_VERSION; }

const char* ms_status_name(ms_status status) {
  switch (status) {
    case MS_OK: return "MS_OK";
    case MS_ERR_INVALID_ARGUMENT: return "MS_ERR_INVALID_ARGUMENT";
    case MS_ERR_NOT_FOUND: return "MS_ERR_NOT_FOUND";
    case MS_ERR_UNAUTHENTICATED: return "MS_ERR_UNAUTHENTICATED";
    case MS_ERR_UNAVAILABLE: return "MS_ERR_UNAVAILABLE";
    case MS_ERR_TIMEOUT: return "MS_ERR_TIMEOUT";
    case MS_ERR_INTERNAL: return "MS_ERR_INTERNAL";
  }
  return "MS_ERR_UNKNOWN";
}

}  // extern "C"
