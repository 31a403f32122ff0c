// The C API (libmeshstream, sdk/include/meshstream/meshstream.h) against a
// real `meshstream serve`: events in order, the mesh views of every level
// equal to decoding the stored progressive file to that level, nothing
// predicted over a clean transport, the argument errors and their messages,
// NOT_FOUND / UNAVAILABLE / UNAUTHENTICATED from the server, the per-thread
// last error, struct_size versioning, cancel, export, and the C example
// (sdk/examples/stream_mesh.c) as CMake builds it and as `cc` builds it with
// pkg-config from the build tree and from an installed tree.
//
// Its own executable, linked against the shared library and no generated
// proto code: libmeshstream registers meshstream/v1/*.proto with the
// process's protobuf, and a second copy in the same process aborts
// (docs/spec/c-api.md, "One copy per process"). So the assets go in through the
// CLI (`meshstream ingest`, `export`) rather than sdk::AssetClient.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <map>
#include <memory>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "codec/mesh/scene_flatten.h"
#include "importers/import.h"
#include "importers/progressive_glb.h"
#include "meshstream/meshstream.h"
#include "tests/common/cli_util.h"
#include "testing/serve_process.h"
#include "testing/loopback_socket.h"
#include "testing/test_util.h"
#include "testing/udp_relay.h"

namespace meshstream {
namespace {

using test_util::Quote;
using test_util::RunCommand;
using test_util::ServeProcess;

struct ClientDeleter {
  void operator()(ms_client* c) const { ms_client_destroy(c); }
};
struct SessionDeleter {
  void operator()(ms_session* s) const { ms_session_close(s); }
};
using ClientPtr = std::unique_ptr<ms_client, ClientDeleter>;
using SessionPtr = std::unique_ptr<ms_session, SessionDeleter>;

ms_client_config ClientConfig(const std::string& server, const char* token = nullptr) {
  ms_client_config c;
  std::memset(&c, 0, sizeof c);
  c.struct_size = sizeof c;
  c.server = server.c_str();
  c.token = token;
  return c;
}

ms_session_config SessionConfig(const char* asset, int32_t max_level = -1) {
  ms_session_config c;
  std::memset(&c, 0, sizeof c);
  c.struct_size = sizeof c;
  c.asset = asset;
  c.max_level = max_level;
  c.tcp_only = 0;  // UDP, the product's path (loopback: nothing lost)
  return c;
}

ms_stats Stats(const ms_session* session) {
  ms_stats s;
  std::memset(&s, 0, sizeof s);
  s.struct_size = sizeof s;
  EXPECT_EQ(ms_session_stats(session, &s), MS_OK) << ms_last_error();
  return s;
}

// A poll's result: what it returned, the event, ms_last_error after it.
struct Polled {
  ms_status returned;
  ms_event event;
  std::string error;
};

// Polls to COMPLETE or ERROR; `at_event` runs after every other event.
template <typename F>
std::vector<Polled> PollToEnd(ms_session* session, F&& at_event) {
  std::vector<Polled> events;
  for (int i = 0; i < 100000; ++i) {
    Polled p;
    p.returned = ms_session_poll(session, 10000, &p.event);
    p.error = ms_last_error();
    if (p.returned == MS_OK && p.event.type == MS_EVENT_NONE) continue;
    events.push_back(p);
    if (p.event.type == MS_EVENT_COMPLETE || p.event.type == MS_EVENT_ERROR || p.returned != MS_OK) break;
    at_event(p.event);
  }
  return events;
}
std::vector<Polled> PollToEnd(ms_session* session) {
  return PollToEnd(session, [](const ms_event&) {});
}

// The first error of a session that cannot start: from ms_session_open, or
// (when the open was only buffered) from its first poll.
std::pair<ms_status, std::string> FirstError(ms_client* client, const ms_session_config& config) {
  ms_session* session = nullptr;
  const ms_status opened = ms_session_open(client, &config, &session);
  if (opened != MS_OK) {
    EXPECT_EQ(session, nullptr);
    return {opened, ms_last_error()};
  }
  SessionPtr owned(session);
  const std::vector<Polled> events = PollToEnd(session);
  EXPECT_EQ(events.size(), 1u);
  if (events.empty()) return {MS_OK, ""};
  EXPECT_EQ(events[0].event.type, MS_EVENT_ERROR);
  EXPECT_EQ(events[0].event.status, events[0].returned);
  return {events[0].returned, events[0].error};
}

// Sums over a session's primitives, from their mesh views.
struct Totals {
  size_t vertices = 0, faces = 0, predicted = 0;
};
Totals Sum(ms_session* session) {
  Totals t;
  for (uint32_t i = 0; i < ms_session_primitive_count(session); ++i) {
    ms_mesh_view v;
    EXPECT_EQ(ms_session_mesh(session, i, &v), MS_OK) << ms_last_error();
    t.vertices += v.vertex_count;
    t.faces += v.index_count / 3;
    for (size_t k = 0; k < v.vertex_count; ++k) t.predicted += v.predicted[k];
  }
  return t;
}

// The decoded primitive that sits where the session's primitive `i` sits.
const Primitive* DecodedAt(const Scene& decoded, const ms_session* session, uint32_t i) {
  uint32_t mesh = 0, primitive = 0;
  EXPECT_EQ(ms_session_gltf_position(session, i, &mesh, &primitive), MS_OK) << ms_last_error();
  if (mesh >= decoded.meshes.size()) return nullptr;
  const std::vector<Mesh::Ref> order = decoded.meshes[mesh].Order();
  if (primitive >= order.size()) return nullptr;
  return &decoded.meshes[mesh].primitives[order[primitive].index];
}

// The session's current meshes are the decoded scene's, value for value.
void ExpectSameMeshes(ms_session* session, const Scene& decoded, const std::string& where) {
  SCOPED_TRACE(where);
  for (uint32_t i = 0; i < ms_session_primitive_count(session); ++i) {
    const Primitive* expected = DecodedAt(decoded, session, i);
    ASSERT_NE(expected, nullptr) << "primitive " << i;
    ms_mesh_view v;
    ASSERT_EQ(ms_session_mesh(session, i, &v), MS_OK) << ms_last_error();
    ASSERT_EQ(v.vertex_count, expected->positions.size()) << "primitive " << i;
    ASSERT_EQ(v.index_count, expected->indices.size()) << "primitive " << i;
    EXPECT_TRUE(std::equal(expected->indices.begin(), expected->indices.end(), v.indices)) << "primitive " << i;
    // Each array equals the decoded attribute, value for value (NULL when it has none).
    auto same = [&](const float* got, const auto& expected_values, size_t components) {
      if (got == nullptr) return expected_values.empty();
      if (expected_values.size() != v.vertex_count) return false;
      for (size_t k = 0; k < v.vertex_count; ++k) {
        for (size_t c = 0; c < components; ++c) {
          if (got[components * k + c] != expected_values[k][c]) return false;
        }
      }
      return true;
    };
    EXPECT_TRUE(same(v.positions, expected->positions, 3)) << "primitive " << i << ": positions differ from the file's decode";
    EXPECT_TRUE(same(v.normals, expected->normals, 3)) << "primitive " << i << ": normals differ";
    EXPECT_EQ(v.normals != nullptr, !expected->normals.empty()) << "primitive " << i;
    const std::vector<Vec2f> no_texcoords;
    EXPECT_TRUE(same(v.texcoords, expected->texcoords.empty() ? no_texcoords : expected->texcoords[0], 2))
        << "primitive " << i << ": texcoords differ";
    EXPECT_EQ(v.texcoords != nullptr, !expected->texcoords.empty()) << "primitive " << i;
    const float* colors = nullptr;
    ASSERT_EQ(ms_session_mesh_colors(session, i, &colors), MS_OK) << ms_last_error();
    EXPECT_TRUE(same(colors, expected->colors, 4)) << "primitive " << i << ": colors differ";
    EXPECT_EQ(colors != nullptr, !expected->colors.empty()) << "primitive " << i;
    ASSERT_NE(v.predicted, nullptr);
    for (size_t k = 0; k < v.vertex_count; ++k) ASSERT_EQ(v.predicted[k], 0) << "primitive " << i << " vertex " << k;
  }
}

// The session's meshes are the stored progressive file decoded to `level`.
void ExpectTheFileAtLevel(ms_session* session, const std::vector<uint8_t>& progressive, int32_t level) {
  ProgressiveDecodeOptions options;
  options.lod = level;
  auto decoded = DecodeProgressiveGlb(progressive, options, nullptr);
  ASSERT_TRUE(decoded.ok()) << decoded.status().ToString();
  ExpectSameMeshes(session, *decoded, "level " + std::to_string(level));
}

size_t SceneVertices(const Scene& scene) {
  size_t n = 0;
  for (const Mesh& m : scene.meshes) {
    for (const Primitive& p : m.primitives) n += p.positions.size();
  }
  return n;
}

// One stored asset: its progressive file as the server exports it, decoded.
struct Stored {
  std::string name;
  std::vector<uint8_t> progressive;
  Scene decoded;
  ProgressiveDecodeReport report;
};

class CApi : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const Status started = suite_.Start();
    ASSERT_TRUE(started.ok()) << started.ToString();
    // spot: one primitive with UVs; engine: 34 primitives with normals;
    // box: a primitive too small to have refinements.
    stored_ = new std::vector<Stored>();
    for (const auto& [name, file] : {std::pair<std::string, std::string>{"spot", "spot.obj"},
                                     {"engine", "gltf/2CylinderEngine.glb"},
                                     {"box", "gltf/BoxTextured.glb"}}) {
      Ingest(*server_, name, test_util::ModelPath(file));
      Stored s;
      s.name = name;
      const std::string path = dir_->File(name + ".progressive.glb");
      test_util::RunCliJson("export --json " + name + " -o " + Quote(path) + " --format progressive --server " +
                            server_->address());
      auto bytes = ReadFileBytes(path, uint64_t{1} << 30);
      ASSERT_TRUE(bytes.ok()) << bytes.status().ToString();
      s.progressive = std::move(bytes).value();
      auto decoded = DecodeProgressiveGlb(s.progressive, ProgressiveDecodeOptions{}, &s.report);
      ASSERT_TRUE(decoded.ok()) << decoded.status().ToString();
      s.decoded = std::move(decoded).value();
      ASSERT_EQ(s.report.level_vertices.size(), s.report.levels + 1) << name;
      stored_->push_back(std::move(s));
    }
  }
  static void TearDownTestSuite() {
    std::string log;
    EXPECT_EQ(suite_.Stop(&log), 0) << log;
    delete stored_;
  }

  static void Ingest(const ServeProcess& server, const std::string& asset, const std::string& file,
                     const std::string& token = "") {
    const nlohmann::json j = test_util::RunCliJson("ingest --json --wait --asset " + asset + " " + Quote(file) +
                                                   " --server " + server.address() +
                                                   (token.empty() ? "" : " --token " + token));
    ASSERT_EQ(j["job"]["state"], "JOB_STATE_SUCCEEDED") << j.dump();
  }

  static const Stored& Asset(const std::string& name) {
    for (const Stored& s : *stored_) {
      if (s.name == name) return s;
    }
    ADD_FAILURE() << name << " was not stored";
    return stored_->front();
  }

  static ClientPtr NewClient() {
    const ms_client_config config = ClientConfig(server_->address());
    ms_client* client = nullptr;
    EXPECT_EQ(ms_client_create(&config, &client), MS_OK) << ms_last_error();
    return ClientPtr(client);
  }

  static SessionPtr Open(ms_client* client, const ms_session_config& config) {
    ms_session* session = nullptr;
    EXPECT_EQ(ms_session_open(client, &config, &session), MS_OK) << ms_last_error();
    return SessionPtr(session);
  }

  static inline test_util::SuiteServer suite_;
  static inline test_util::TempDir*& dir_ = suite_.dir;
  static inline ServeProcess*& server_ = suite_.server;
  static inline std::vector<Stored>* stored_ = nullptr;
};

TEST_F(CApi, EventsInOrderWithTheMeshesOfEachLevel) {
  ClientPtr client = NewClient();
  ASSERT_NE(client, nullptr);
  for (const Stored& stored : *stored_) {
    SCOPED_TRACE(stored.name);
    SessionPtr session = Open(client.get(), SessionConfig(stored.name.c_str()));
    ASSERT_NE(session, nullptr);
    EXPECT_EQ(ms_session_primitive_count(session.get()), 0u) << "nothing before the base";
    std::vector<size_t> vertices_at;  // per event
    const std::vector<Polled> events = PollToEnd(session.get(), [&](const ms_event& e) {
      const Totals t = Sum(session.get());
      vertices_at.push_back(t.vertices);
      EXPECT_EQ(t.predicted, 0u) << "nothing is predicted without loss (level " << e.level
                                 << "; datagrams lost: " << Stats(session.get()).datagrams_lost << ")";
    });
    ASSERT_FALSE(events.empty());
    ASSERT_EQ(events.back().event.type, MS_EVENT_COMPLETE) << events.back().error;
    EXPECT_EQ(events.back().returned, MS_OK);
    ASSERT_EQ(events.front().event.type, MS_EVENT_BASE_READY);
    EXPECT_EQ(events.front().event.level, 0);
    const int32_t levels = static_cast<int32_t>(stored.report.levels);
    // BASE_READY, LEVEL_READY with increasing levels (levels completed in
    // one poll come as one event), the last at every level, COMPLETE.
    ASSERT_GE(events.size(), levels > 0 ? 3u : 2u);
    ASSERT_LE(events.size(), static_cast<size_t>(levels) + 2);
    int32_t previous = 0;
    for (size_t k = 1; k + 1 < events.size(); ++k) {
      const Polled& p = events[k];
      EXPECT_EQ(p.event.type, MS_EVENT_LEVEL_READY) << k;
      EXPECT_GT(p.event.level, previous);
      previous = p.event.level;
      EXPECT_EQ(p.event.status, MS_OK);
      EXPECT_EQ(p.returned, MS_OK);
      EXPECT_EQ(p.error, "") << "a call that returned MS_OK leaves no error";
    }
    EXPECT_EQ(previous, levels);
    EXPECT_EQ(events.back().event.level, levels);
    // At every event the views hold what the file has at the event's level.
    ASSERT_EQ(vertices_at.size(), events.size() - 1);
    for (size_t k = 0; k + 1 < events.size(); ++k) {
      const int32_t level = events[k].event.level;
      EXPECT_EQ(vertices_at[k], stored.report.level_vertices[static_cast<size_t>(level)]) << "level " << level;
    }
    ExpectSameMeshes(session.get(), stored.decoded, "final");
    size_t refined = 0;
    for (const Mesh& m : stored.decoded.meshes) refined += m.primitives.size();
    EXPECT_EQ(ms_session_primitive_count(session.get()), refined);
    const ms_stats stats = Stats(session.get());
    EXPECT_EQ(stats.levels, levels);
    EXPECT_EQ(stats.level_shown, levels);
    EXPECT_EQ(stats.primitive_count, ms_session_primitive_count(session.get()));
    EXPECT_GT(stats.primitive_count, 0u);
    EXPECT_STREQ(stats.transport, "udp");
    EXPECT_GT(stats.reliable_bytes, 0u);
    EXPECT_EQ(stats.predicted_vertices, 0u);
    EXPECT_EQ(stats.datagrams_rejected, 0u);
    if (levels > 0) { EXPECT_GT(stats.datagrams_received, 0u); }
    EXPECT_GT(stats.time_to_base_ms, 0.0);
    EXPECT_GE(stats.time_to_full_ms, stats.time_to_base_ms);
    {
      // The decoding left after the last arrival: written (the caller's -1 replaced), within the time to full.
      ms_stats where;
      std::memset(&where, 0, sizeof where);
      where.struct_size = sizeof where;
      where.decode_after_last_byte_ms = -1;
      ASSERT_EQ(ms_session_stats(session.get(), &where), MS_OK) << ms_last_error();
      EXPECT_GE(where.decode_after_last_byte_ms, 0.0);
      EXPECT_LE(where.decode_after_last_byte_ms, where.time_to_full_ms);
    }
    // Over: the next poll returns at once with nothing.
    ms_event after;
    EXPECT_EQ(ms_session_poll(session.get(), 5000, &after), MS_OK);
    EXPECT_EQ(after.type, MS_EVENT_NONE);
  }
  const Stored& engine = Asset("engine");
  size_t primitives = 0;
  for (const Mesh& m : engine.decoded.meshes) primitives += m.primitives.size();
  EXPECT_GT(primitives, 1u) << "the engine is the multi-primitive case";
}

// A host's copy of a primitive's arrays, kept up to date by the changed
// ranges alone (what a renderer's GPU buffers are).
struct HostCopy {
  std::vector<float> positions, normals, texcoords;
  std::vector<uint8_t> predicted;
  std::vector<uint32_t> indices;
  uint64_t vertices_written = 0, indices_written = 0;
};

template <typename T>
void CopyRanges(std::vector<T>& to, const T* from, size_t count, size_t per_element, const ms_range* ranges,
                uint32_t range_count) {
  to.resize(count * per_element);
  if (from == nullptr) return;
  for (uint32_t i = 0; i < range_count; ++i) {
    ASSERT_LE(size_t{ranges[i].first} + ranges[i].count, count) << "range " << i << " ends past the view";
    std::memcpy(to.data() + size_t{ranges[i].first} * per_element, from + size_t{ranges[i].first} * per_element,
                size_t{ranges[i].count} * per_element * sizeof(T));
  }
}

void ExpectRangesRebuildEveryView(ms_client* client, const char* asset, uint32_t max_ranges) {
  SCOPED_TRACE(std::string(asset) + ", max_ranges " + std::to_string(max_ranges));
  ms_session_config config = SessionConfig(asset);
  ms_session* raw = nullptr;
  ASSERT_EQ(ms_session_open(client, &config, &raw), MS_OK) << ms_last_error();
  SessionPtr session(raw);
  std::vector<HostCopy> host;
  uint64_t reuploaded_vertices = 0;  // what uploading every view whole would write
  uint64_t final_vertices = 0;
  int events = 0;
  PollToEnd(session.get(), [&](const ms_event& e) {
    ++events;
    const uint32_t count = ms_session_primitive_count(session.get());
    host.resize(count);
    final_vertices = 0;
    for (uint32_t i = 0; i < count; ++i) {
      ms_mesh_changes c;
      std::memset(&c, 0, sizeof c);
      c.struct_size = sizeof c;
      c.max_ranges = max_ranges;
      ASSERT_EQ(ms_session_mesh_changes(session.get(), i, &c), MS_OK) << ms_last_error();
      ms_mesh_view v;
      ASSERT_EQ(ms_session_mesh(session.get(), i, &v), MS_OK) << ms_last_error();
      EXPECT_EQ(c.everything != 0, e.type == MS_EVENT_BASE_READY) << "level " << e.level << " primitive " << i;
      if (max_ranges > 0) {
        EXPECT_LE(c.vertex_range_count, max_ranges);
        EXPECT_LE(c.index_range_count, max_ranges);
      }
      uint64_t covered = 0;
      for (uint32_t r = 0; r < c.vertex_range_count; ++r) {
        covered += c.vertex_ranges[r].count;
        if (r > 0) EXPECT_GT(c.vertex_ranges[r].first, c.vertex_ranges[r - 1].first + c.vertex_ranges[r - 1].count);
      }
      EXPECT_EQ(covered, c.changed_vertices);
      covered = 0;
      for (uint32_t r = 0; r < c.index_range_count; ++r) covered += c.index_ranges[r].count;
      EXPECT_EQ(covered, c.changed_indices);
      // Asking again before the next poll: the same answer.
      ms_mesh_changes again = c;
      ASSERT_EQ(ms_session_mesh_changes(session.get(), i, &again), MS_OK);
      EXPECT_EQ(again.changed_vertices, c.changed_vertices);
      EXPECT_EQ(again.changed_indices, c.changed_indices);
      HostCopy& h = host[i];
      CopyRanges(h.positions, v.positions, v.vertex_count, 3, c.vertex_ranges, c.vertex_range_count);
      CopyRanges(h.normals, v.normals, v.normals ? v.vertex_count : 0, 3, c.vertex_ranges, c.vertex_range_count);
      CopyRanges(h.texcoords, v.texcoords, v.texcoords ? v.vertex_count : 0, 2, c.vertex_ranges, c.vertex_range_count);
      CopyRanges(h.predicted, v.predicted, v.vertex_count, 1, c.vertex_ranges, c.vertex_range_count);
      CopyRanges(h.indices, v.indices, v.index_count, 1, c.index_ranges, c.index_range_count);
      h.vertices_written += c.changed_vertices;
      h.indices_written += c.changed_indices;
      // The host's copy, written only where the ranges said, is the view.
      ASSERT_EQ(h.positions.size(), 3 * v.vertex_count);
      EXPECT_EQ(std::memcmp(h.positions.data(), v.positions, h.positions.size() * sizeof(float)), 0) << "positions";
      if (v.normals) { EXPECT_EQ(std::memcmp(h.normals.data(), v.normals, h.normals.size() * sizeof(float)), 0); }
      if (v.texcoords) { EXPECT_EQ(std::memcmp(h.texcoords.data(), v.texcoords, h.texcoords.size() * sizeof(float)), 0); }
      EXPECT_EQ(std::memcmp(h.predicted.data(), v.predicted, h.predicted.size()), 0) << "predicted";
      ASSERT_EQ(h.indices.size(), v.index_count);
      EXPECT_EQ(std::memcmp(h.indices.data(), v.indices, h.indices.size() * sizeof(uint32_t)), 0) << "indices";
      reuploaded_vertices += v.vertex_count;
      final_vertices += v.vertex_count;
    }
  });
  ASSERT_GE(events, 3) << "a base and at least two levels";
  uint64_t written = 0;
  for (const HostCopy& h : host) written += h.vertices_written;
  // Fewer vertices written than uploading every view whole, and at least the final mesh.
  EXPECT_LT(written, reuploaded_vertices);
  EXPECT_GE(written, final_vertices);
}

TEST_F(CApi, ChangedRangesRebuildEveryViewFromTheRangesAlone) {
  ClientPtr client = NewClient();
  ASSERT_NE(client, nullptr);
  for (const char* asset : {"spot", "engine"}) {
    ExpectRangesRebuildEveryView(client.get(), asset, 0);
    ExpectRangesRebuildEveryView(client.get(), asset, 8);
  }
}

TEST_F(CApi, InstancesAreTheSceneNodesWorldMatrices) {
  ClientPtr client = NewClient();
  ASSERT_NE(client, nullptr);
  const Stored& engine = Asset("engine");
  SessionPtr session = Open(client.get(), SessionConfig("engine", 0));
  const std::vector<Polled> events = PollToEnd(session.get());
  ASSERT_EQ(events.back().event.type, MS_EVENT_COMPLETE) << events.back().error;
  std::map<int32_t, std::vector<Mat4d>> by_mesh;
  ForEachMeshInstance(engine.decoded, [&](int32_t mesh, const Mat4d& world, bool) { by_mesh[mesh].push_back(world); });
  bool some_not_identity = false;
  for (uint32_t i = 0; i < ms_session_primitive_count(session.get()); ++i) {
    uint32_t mesh = 0, mesh_primitive = 0;
    ASSERT_EQ(ms_session_gltf_position(session.get(), i, &mesh, &mesh_primitive), MS_OK);
    const float* matrices = nullptr;
    uint32_t count = 0;
    ASSERT_EQ(ms_session_instances(session.get(), i, &matrices, &count), MS_OK) << ms_last_error();
    const std::vector<Mat4d>& want = by_mesh[static_cast<int32_t>(mesh)];
    ASSERT_EQ(count, want.size()) << "primitive " << i;
    ASSERT_GT(count, 0u);
    for (uint32_t k = 0; k < count; ++k) {
      for (int e = 0; e < 16; ++e) {
        EXPECT_EQ(matrices[16 * k + e], static_cast<float>(want[k][e])) << "primitive " << i << " instance " << k;
        if ((e % 5 == 0 ? 1.0 : 0.0) != want[k][e]) some_not_identity = true;
      }
    }
  }
  EXPECT_TRUE(some_not_identity) << "the engine's nodes move its parts";
  const float* m = nullptr;
  uint32_t c = 0;
  EXPECT_EQ(ms_session_instances(session.get(), 9999, &m, &c), MS_ERR_INVALID_ARGUMENT);
  EXPECT_EQ(ms_session_instances(session.get(), 0, nullptr, &c), MS_ERR_INVALID_ARGUMENT);
  EXPECT_STREQ(ms_last_error(), "out_matrices: must not be NULL");
}

TEST_F(CApi, ChangesBeforeTheBaseAndBadArguments) {
  ClientPtr client = NewClient();
  ASSERT_NE(client, nullptr);
  SessionPtr session = Open(client.get(), SessionConfig("spot"));
  ms_mesh_changes c;
  std::memset(&c, 0, sizeof c);
  c.struct_size = sizeof c;
  EXPECT_EQ(ms_session_mesh_changes(nullptr, 0, &c), MS_ERR_INVALID_ARGUMENT);
  EXPECT_STREQ(ms_last_error(), "session: must not be NULL");
  EXPECT_EQ(ms_session_mesh_changes(session.get(), 0, nullptr), MS_ERR_INVALID_ARGUMENT);
  EXPECT_STREQ(ms_last_error(), "out: must not be NULL");
  EXPECT_EQ(ms_session_mesh_changes(session.get(), 0, &c), MS_ERR_INVALID_ARGUMENT);
  EXPECT_NE(std::string(ms_last_error()).find("primitive: 0 does not exist"), std::string::npos) << ms_last_error();
  c.struct_size = 8;
  EXPECT_EQ(ms_session_mesh_changes(session.get(), 0, &c), MS_ERR_INVALID_ARGUMENT);
  EXPECT_NE(std::string(ms_last_error()).find("out->struct_size"), std::string::npos) << ms_last_error();
}

TEST_F(CApi, EveryLevelIsTheStoredFileDecodedToThatLevel) {
  const Stored& spot = Asset("spot");
  ClientPtr client = NewClient();
  SessionPtr session = Open(client.get(), SessionConfig("spot"));
  ASSERT_NE(session, nullptr);
  int checked = 0;
  const auto events = PollToEnd(session.get(), [&](const ms_event& e) {
    ExpectTheFileAtLevel(session.get(), spot.progressive, e.level);
    // Asking again before the next poll gives the same arrays.
    ms_mesh_view a, b;
    ASSERT_EQ(ms_session_mesh(session.get(), 0, &a), MS_OK);
    ASSERT_EQ(ms_session_mesh(session.get(), 0, &b), MS_OK);
    EXPECT_EQ(a.positions, b.positions);
    EXPECT_EQ(a.indices, b.indices);
    EXPECT_EQ(a.predicted, b.predicted);
    ++checked;
  });
  ASSERT_EQ(events.back().event.type, MS_EVENT_COMPLETE) << events.back().error;
  EXPECT_EQ(checked, static_cast<int>(events.size()) - 1) << "every event but COMPLETE was checked";
  EXPECT_GE(checked, 2);
}

TEST_F(CApi, MaxLevelStopsEarly) {
  ClientPtr client = NewClient();
  for (int32_t max_level : {0, 3}) {
    SCOPED_TRACE(max_level);
    SessionPtr session = Open(client.get(), SessionConfig("spot", max_level));
    ASSERT_NE(session, nullptr);
    const auto events = PollToEnd(session.get());
    ASSERT_LE(events.size(), static_cast<size_t>(max_level) + 2);
    ASSERT_GE(events.size(), max_level == 0 ? 2u : 3u);
    EXPECT_EQ(events.front().event.type, MS_EVENT_BASE_READY);
    ASSERT_EQ(events.back().event.type, MS_EVENT_COMPLETE) << events.back().error;
    EXPECT_EQ(events.back().event.level, max_level);
    EXPECT_EQ(Stats(session.get()).levels, max_level);
    EXPECT_EQ(Sum(session.get()).vertices, Asset("spot").report.level_vertices[static_cast<size_t>(max_level)]);
  }
}

// The fields after the first version: a byte budget ends the session early
// with COMPLETE; over clean loopback UDP nothing is lost and the HELLO round
// trip is measured.
TEST_F(CApi, ByteBudgetAndTheCountersAfterTheFirstVersion) {
  ClientPtr client = NewClient();
  ms_session_config budget = SessionConfig("engine", -1);
  budget.byte_budget = 20000;
  SessionPtr cut = Open(client.get(), budget);
  ASSERT_NE(cut, nullptr);
  auto events = PollToEnd(cut.get());
  ASSERT_EQ(events.back().event.type, MS_EVENT_COMPLETE) << events.back().error;
  const ms_stats b = Stats(cut.get());
  EXPECT_LT(b.level_shown, b.levels) << "the budget stopped it early";
  EXPECT_GE(b.reliable_bytes + b.unreliable_bytes, 20000u);

  SessionPtr full = Open(client.get(), SessionConfig("spot", -1));
  ASSERT_NE(full, nullptr);
  events = PollToEnd(full.get());
  ASSERT_EQ(events.back().event.type, MS_EVENT_COMPLETE) << events.back().error;
  const ms_stats f = Stats(full.get());
  EXPECT_STREQ(f.transport, "udp");
  EXPECT_EQ(f.datagrams_lost, 0u);
  // A datagram that came as UDP came after the HELLO_ACK on the same
  // loopback socket, so the round trip was measured. (On loopback a small
  // asset may all go on the stream before the HELLO proves the address;
  // then there is no UDP datagram and nothing to say about the RTT.)
  const uint64_t udp_bytes = f.unreliable_bytes - f.reliable_datagram_bytes - f.early_datagram_bytes;
  if (udp_bytes > 0) {
    EXPECT_GT(f.hello_rtt_ms, 0.0) << udp_bytes << " datagram bytes came as UDP";
  }
  EXPECT_GT(f.datagrams_received, 0u);
  // A negative time budget is refused, naming the field.
  ms_session_config bad = SessionConfig("spot", -1);
  bad.time_budget_ms = -1;
  ms_session* none = nullptr;
  EXPECT_EQ(ms_session_open(client.get(), &bad, &none), MS_ERR_INVALID_ARGUMENT);
  EXPECT_NE(std::string(ms_last_error()).find("time_budget_ms"), std::string::npos) << ms_last_error();
  // So is a thread count outside -1..64.
  ms_session_config threads = SessionConfig("spot", -1);
  threads.decode_threads = -2;
  EXPECT_EQ(ms_session_open(client.get(), &threads, &none), MS_ERR_INVALID_ARGUMENT);
  EXPECT_NE(std::string(ms_last_error()).find("decode_threads"), std::string::npos) << ms_last_error();
}

// config->decode_threads: the session decodes whole refinements on a pool of
// threads, and every level is the stored file's decode, bit for bit.
TEST_F(CApi, DecodeThreadsGiveTheSameMeshes) {
  const Stored& spot = Asset("spot");
  ClientPtr client = NewClient();
  ms_session_config config = SessionConfig("spot");
  config.tcp_only = 1;  // nothing lost: every refinement arrives whole
  config.decode_threads = 2;
  SessionPtr session = Open(client.get(), config);
  ASSERT_NE(session, nullptr);
  const auto events = PollToEnd(session.get(),
                                [&](const ms_event& e) { ExpectTheFileAtLevel(session.get(), spot.progressive, e.level); });
  ASSERT_EQ(events.back().event.type, MS_EVENT_COMPLETE) << events.back().error;
  EXPECT_GT(Stats(session.get()).parallel_splits, 0u);
  SessionPtr one = Open(client.get(), SessionConfig("spot"));
  ASSERT_NE(one, nullptr);
  ASSERT_EQ(PollToEnd(one.get()).back().event.type, MS_EVENT_COMPLETE);
  EXPECT_EQ(Stats(one.get()).parallel_splits, 0u);
}

// config->repair and the counters beside it: on loopback nothing is lost, so
// the repair asks for nothing and the mesh is exact when COMPLETE comes; the
// server's reliable cut shows as datagram bytes that came on the stream.
TEST_F(CApi, RepairAndTheReliableCutCounters) {
  ClientPtr client = NewClient();
  ms_session_config config = SessionConfig("spot", -1);
  config.repair = 1;
  SessionPtr session = Open(client.get(), config);
  ASSERT_NE(session, nullptr);
  const auto events = PollToEnd(session.get());
  ASSERT_EQ(events.back().event.type, MS_EVENT_COMPLETE) << events.back().error;
  const ms_stats s = Stats(session.get());
  EXPECT_EQ(s.datagrams_lost, 0u);
  EXPECT_EQ(s.repaired_datagrams, 0u);
  EXPECT_GT(s.time_to_exact_ms, 0.0);
  EXPECT_DOUBLE_EQ(s.time_to_exact_ms, s.time_to_full_ms) << "nothing lost: exact at once";
  EXPECT_GT(s.reliable_datagram_bytes, 0u);
  EXPECT_EQ(s.predicted_vertices, 0u);
}

// config->no_parity through a relay that loses 30 % of what goes to the
// client: a session with no_parity gets no parity datagrams and rebuilds
// nothing (what it lost stays predicted); the next one on the same client,
// without it, gets parity and rebuilds (what parity rebuilds is
// StreamOverRelay's test). Deterministic, whatever the machine's timing: the
// server waits for the HELLO before the first refinement (--udp-wait-hello)
// and keeps no reliable cut, so every refinement travels as UDP through the
// relay; the second session states the loss the client remembers from the
// first (LossMemory), so parity is sized from its first datagram instead of
// after a report (which a small asset may never wait for). Before, the
// engine was often all sent on the stream before a HELLO proved the address
// (the relay may lose the HELLO_ACK), and nothing was lost.
TEST_F(CApi, NoParityMeansNoParityDatagrams) {
  test_util::TempDir dir;
  auto server = ServeProcess::Start(
      {"--store", dir.File("store"), "--workers", "1", "--udp-wait-hello", "--no-reliable-cut", "--hello-timeout", "5000"});
  ASSERT_TRUE(server.ok()) << server.status().ToString();
  Ingest(**server, "engine", test_util::ModelPath("gltf/2CylinderEngine.glb"));
  const ms_client_config cc = ClientConfig((*server)->address());
  ms_client* raw = nullptr;
  ASSERT_EQ(ms_client_create(&cc, &raw), MS_OK) << ms_last_error();
  ClientPtr client(raw);
  auto run = [&](int32_t no_parity) {
    test_util::RelayOptions o;
    o.upstream = SocketAddress::Parse((*server)->udp_address()).value();
    o.to_client = LinkModel::Loss(0.30, 7);
    auto relay = test_util::UdpRelay::Start(o);
    EXPECT_TRUE(relay.ok()) << relay.status().ToString();
    const std::string via = relay.value()->front().ToString();
    ms_session_config config = SessionConfig("engine", -1);
    config.udp_via = via.c_str();
    config.no_parity = no_parity;
    SessionPtr session = Open(client.get(), config);
    EXPECT_NE(session, nullptr);
    const auto events = PollToEnd(session.get());
    EXPECT_EQ(events.back().event.type, MS_EVENT_COMPLETE) << events.back().error;
    return Stats(session.get());
  };
  const ms_stats without = run(1), with = run(0);
  EXPECT_EQ(without.early_datagram_bytes, 0u) << "nothing before the HELLO";
  EXPECT_GT(without.datagrams_lost, 0u);
  EXPECT_EQ(without.parity_datagrams, 0u);
  EXPECT_EQ(without.datagrams_recovered, 0u);
  EXPECT_GT(without.predicted_vertices, 0u) << "what was lost stays predicted";
  EXPECT_GT(with.datagrams_lost, 0u);
  EXPECT_GT(with.parity_datagrams, 0u);
  EXPECT_GT(with.datagrams_recovered, 0u);
}

// Every argument error: its status, and a message naming the argument.
TEST_F(CApi, ArgumentErrorsNameTheArgument) {
  auto expect = [](ms_status got, const std::string& needle, const std::string& what) {
    EXPECT_EQ(got, MS_ERR_INVALID_ARGUMENT) << what << ": " << ms_last_error();
    EXPECT_NE(std::string(ms_last_error()).find(needle), std::string::npos)
        << what << ": \"" << ms_last_error() << "\" does not name " << needle;
  };
  const std::string address = server_->address();
  ms_client_config cc = ClientConfig(address);
  ms_client* client = reinterpret_cast<ms_client*>(&cc);  // not NULL, to see that a failure resets *out
  expect(ms_client_create(nullptr, &client), "config", "NULL config");
  EXPECT_EQ(client, nullptr) << "*out is NULL after a failure";
  expect(ms_client_create(&cc, nullptr), "out", "NULL out");
  cc.struct_size = 0;
  expect(ms_client_create(&cc, &client), "config->struct_size", "struct_size 0");
  cc.struct_size = MS_CLIENT_CONFIG_V0_SIZE - 1;
  expect(ms_client_create(&cc, &client), "config->struct_size", "struct_size below the first version");
  cc = ClientConfig("");
  EXPECT_EQ(ms_client_create(&cc, &client), MS_ERR_INVALID_ARGUMENT);
  EXPECT_NE(std::string(ms_last_error()).find("server"), std::string::npos) << ms_last_error();

  ClientPtr good = NewClient();
  ms_session* session = nullptr;
  ms_session_config sc = SessionConfig("spot");
  expect(ms_session_open(nullptr, &sc, &session), "client", "NULL client");
  expect(ms_session_open(good.get(), nullptr, &session), "config", "NULL session config");
  expect(ms_session_open(good.get(), &sc, nullptr), "out", "NULL session out");
  sc.struct_size = 0;
  expect(ms_session_open(good.get(), &sc, &session), "config->struct_size", "session struct_size 0");
  sc.struct_size = MS_SESSION_CONFIG_V0_SIZE - 1;
  expect(ms_session_open(good.get(), &sc, &session), "config->struct_size", "session struct_size too small");
  sc = SessionConfig(nullptr);
  expect(ms_session_open(good.get(), &sc, &session), "config->asset", "NULL asset");
  sc = SessionConfig("");
  expect(ms_session_open(good.get(), &sc, &session), "asset", "empty asset");
  sc = SessionConfig("spot", -2);
  expect(ms_session_open(good.get(), &sc, &session), "max_level", "max_level -2");
  EXPECT_EQ(session, nullptr);

  ms_event e;
  expect(ms_session_poll(nullptr, 0, &e), "session", "poll NULL session");
  EXPECT_EQ(e.type, MS_EVENT_NONE);
  EXPECT_EQ(e.status, MS_ERR_INVALID_ARGUMENT);
  ms_mesh_view view;
  expect(ms_session_mesh(nullptr, 0, &view), "session", "mesh NULL session");
  const float* colors = nullptr;
  expect(ms_session_mesh_colors(nullptr, 0, &colors), "session", "colors NULL session");
  uint32_t m = 0, p = 0;
  expect(ms_session_gltf_position(nullptr, 0, &m, &p), "session", "gltf_position NULL session");
  ms_stats stats;
  stats.struct_size = sizeof stats;
  expect(ms_session_stats(nullptr, &stats), "session", "stats NULL session");
  expect(ms_session_export(nullptr, "x.glb"), "session", "export NULL session");
  expect(ms_session_cancel(nullptr), "session", "cancel NULL session");
  EXPECT_EQ(ms_session_primitive_count(nullptr), 0u);
  EXPECT_NE(std::string(ms_last_error()).find("session"), std::string::npos) << ms_last_error();
  ms_session_close(nullptr);   // no-ops, like free(NULL)
  ms_client_destroy(nullptr);

  // On a live session: NULL outputs, primitives out of range, struct_size.
  SessionPtr live = Open(good.get(), SessionConfig("spot"));
  ASSERT_NE(live, nullptr);
  view.vertex_count = 77;
  expect(ms_session_mesh(live.get(), 0, &view), "primitive: 0", "mesh before the base");
  EXPECT_EQ(view.vertex_count, 0u) << "the view is cleared";
  expect(ms_session_export(live.get(), test_util::TempDir().File("early.glb").c_str()), "base",
         "export before the base");
  const auto events = PollToEnd(live.get());
  ASSERT_EQ(events.back().event.type, MS_EVENT_COMPLETE) << events.back().error;
  const uint32_t count = ms_session_primitive_count(live.get());
  ASSERT_EQ(count, 1u);
  expect(ms_session_poll(live.get(), 0, nullptr), "out", "poll NULL out");
  expect(ms_session_mesh(live.get(), 0, nullptr), "out", "mesh NULL out");
  expect(ms_session_mesh(live.get(), count, &view), "primitive: 1", "mesh out of range");
  expect(ms_session_mesh(live.get(), UINT32_MAX, &view), "primitive: 4294967295", "mesh far out of range");
  expect(ms_session_mesh_colors(live.get(), 0, nullptr), "out_rgba", "colors NULL out");
  expect(ms_session_mesh_colors(live.get(), count, &colors), "primitive: 1", "colors out of range");
  expect(ms_session_gltf_position(live.get(), count, &m, &p), "primitive: 1", "gltf_position out of range");
  expect(ms_session_gltf_position(live.get(), 0, nullptr, &p), "mesh", "gltf_position NULL mesh");
  expect(ms_session_gltf_position(live.get(), 0, &m, nullptr), "mesh_primitive", "gltf_position NULL mesh_primitive");
  expect(ms_session_stats(live.get(), nullptr), "out", "stats NULL out");
  stats.struct_size = 0;
  expect(ms_session_stats(live.get(), &stats), "out->struct_size", "stats struct_size 0");
  expect(ms_session_export(live.get(), nullptr), "path", "export NULL path");
  // A path that cannot be written is the file's error, not a crash.
  EXPECT_EQ(ms_session_export(live.get(), "/nonexistent-folder/x.glb"), MS_ERR_INTERNAL) << ms_last_error();
  EXPECT_NE(std::string(ms_last_error()).find("/nonexistent-folder/x.glb"), std::string::npos) << ms_last_error();
  // And a good call after all that clears the error.
  EXPECT_EQ(ms_session_gltf_position(live.get(), 0, &m, &p), MS_OK);
  EXPECT_STREQ(ms_last_error(), "");
}

TEST_F(CApi, UnknownAssetIsNotFoundNamingTheAsset) {
  ClientPtr client = NewClient();
  SessionPtr session = Open(client.get(), SessionConfig("no-such-asset"));
  ASSERT_NE(session, nullptr) << "the server's answer comes with the first poll";
  const auto events = PollToEnd(session.get());
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].returned, MS_ERR_NOT_FOUND) << events[0].error;
  EXPECT_EQ(events[0].event.type, MS_EVENT_ERROR);
  EXPECT_EQ(events[0].event.status, MS_ERR_NOT_FOUND);
  EXPECT_NE(events[0].error.find("no-such-asset"), std::string::npos) << events[0].error;
  ms_event after;
  EXPECT_EQ(ms_session_poll(session.get(), 1000, &after), MS_OK) << "the session is over";
  EXPECT_EQ(after.type, MS_EVENT_NONE);
}

TEST_F(CApi, UnreachableServerIsUnavailable) {
  // A port nothing listens on: bound, then closed.
  const std::string address = test_util::UnusedLoopbackAddress();
  ASSERT_FALSE(address.empty());
  const ms_client_config config = ClientConfig(address);
  ms_client* raw = nullptr;
  ASSERT_EQ(ms_client_create(&config, &raw), MS_OK) << "creating a client does not connect";
  ClientPtr client(raw);
  const auto [status, error] = FirstError(client.get(), SessionConfig("spot"));
  EXPECT_EQ(status, MS_ERR_UNAVAILABLE) << error;
  EXPECT_FALSE(error.empty());
}

// ms_client_config.deadline_ms against a listener that takes the connection
// and never speaks: the session ends with MS_ERR_TIMEOUT once the deadline
// ran out. Without the deadline the call would wait for gRPC's own connect
// timeout (20 s) and end UNAVAILABLE.
TEST_F(CApi, DeadlineAgainstAStalledListenerIsTimeout) {
  // The kernel completes the handshake; nobody ever accepts.
  test_util::LoopbackSocket listener(true);
  ASSERT_TRUE(listener.ok());
  const std::string address = listener.address();
  ms_client_config config = ClientConfig(address);
  config.deadline_ms = 300;
  ms_client* raw = nullptr;
  ASSERT_EQ(ms_client_create(&config, &raw), MS_OK) << ms_last_error();
  ClientPtr client(raw);
  const auto start = std::chrono::steady_clock::now();
  const auto [status, error] = FirstError(client.get(), SessionConfig("spot"));
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  listener.Close();
  EXPECT_EQ(status, MS_ERR_TIMEOUT) << error;
  EXPECT_NE(error.find("DEADLINE_EXCEEDED"), std::string::npos) << error;
  EXPECT_GE(seconds, 0.25) << "the deadline, not something else, ended it";
  EXPECT_LT(seconds, 5.0) << "the deadline of 300 ms was not applied";
  // A negative deadline is refused, naming the field.
  config.deadline_ms = -1;
  EXPECT_EQ(ms_client_create(&config, &raw), MS_ERR_INVALID_ARGUMENT);
  EXPECT_NE(std::string(ms_last_error()).find("config->deadline_ms"), std::string::npos) << ms_last_error();
}

// A deadline a session meets changes nothing.
TEST_F(CApi, ADeadlineTheSessionMeetsChangesNothing) {
  const std::string address = server_->address();
  ms_client_config config = ClientConfig(address);
  config.deadline_ms = 60000;
  ms_client* raw = nullptr;
  ASSERT_EQ(ms_client_create(&config, &raw), MS_OK) << ms_last_error();
  ClientPtr client(raw);
  SessionPtr session = Open(client.get(), SessionConfig("engine"));
  ASSERT_NE(session, nullptr);
  const auto events = PollToEnd(session.get());
  ASSERT_FALSE(events.empty());
  EXPECT_EQ(events.back().event.type, MS_EVENT_COMPLETE) << events.back().error;
}

TEST_F(CApi, TokensAndUnauthenticated) {
  test_util::TempDir dir;
  const std::string store = dir.File("store");
  auto server = ServeProcess::Start({"--store", store, "--auth", "--workers", "1"});
  ASSERT_TRUE(server.ok()) << server.status().ToString();
  const auto created = RunCommand(test_util::Cli() + " token create --store " + Quote(store) + " --tenant studio");
  ASSERT_EQ(created.exit_code, 0) << created.err;
  std::string token = created.out;
  while (!token.empty() && token.back() == '\n') token.pop_back();
  token = token.substr(token.rfind('\n') == std::string::npos ? 0 : token.rfind('\n') + 1);
  ASSERT_EQ(token.rfind("mst_", 0), 0u) << token;
  Ingest(**server, "spot", test_util::ModelPath("spot.obj"), token);

  for (const std::string& bad : {std::string(), "mst_" + std::string(64, '0')}) {
    SCOPED_TRACE(bad.empty() ? "no token" : "a token the server does not know");
    const ms_client_config config = ClientConfig((*server)->address(), bad.empty() ? nullptr : bad.c_str());
    ms_client* raw = nullptr;
    ASSERT_EQ(ms_client_create(&config, &raw), MS_OK);
    ClientPtr client(raw);
    const auto [status, error] = FirstError(client.get(), SessionConfig("spot"));
    EXPECT_EQ(status, MS_ERR_UNAUTHENTICATED) << error;
    EXPECT_FALSE(error.empty());
  }
  const ms_client_config config = ClientConfig((*server)->address(), token.c_str());
  ms_client* raw = nullptr;
  ASSERT_EQ(ms_client_create(&config, &raw), MS_OK);
  ClientPtr client(raw);
  SessionPtr session = Open(client.get(), SessionConfig("spot"));
  const auto events = PollToEnd(session.get());
  ASSERT_EQ(events.back().event.type, MS_EVENT_COMPLETE) << events.back().error;
  EXPECT_EQ(Sum(session.get()).vertices, Asset("spot").report.level_vertices.back());
  session.reset();
  client.reset();

  // The example: the token from MESHSTREAM_TOKEN, or --token; none fails.
  const test_util::TempDir out;
  const std::string base = Quote(MESHSTREAM_C_EXAMPLE) + " " + (*server)->address() + " spot ";
  const auto from_env = RunCommand("MESHSTREAM_TOKEN=" + token + " " + base + Quote(out.File("a.glb")) + " --tcp-only");
  EXPECT_EQ(from_env.exit_code, 0) << from_env.err;
  const auto from_flag = RunCommand("MESHSTREAM_TOKEN=wrong " + base + Quote(out.File("b.glb")) + " --token " + token);
  EXPECT_EQ(from_flag.exit_code, 0) << from_flag.err << " (--token wins over the environment)";
  const auto none = RunCommand("env -u MESHSTREAM_TOKEN " + base + Quote(out.File("c.glb")));
  EXPECT_EQ(none.exit_code, 1);
  EXPECT_NE(none.err.find("MS_ERR_UNAUTHENTICATED"), std::string::npos) << none.err;
  EXPECT_EQ((*server)->Terminate(), 0) << (*server)->log();
}

TEST_F(CApi, LastErrorIsPerThread) {
  ms_event e;
  ASSERT_EQ(ms_session_poll(nullptr, 0, &e), MS_ERR_INVALID_ARGUMENT);
  const std::string here = ms_last_error();
  ASSERT_NE(here.find("session"), std::string::npos);
  std::string there_before, there_after;
  std::thread other([&] {
    there_before = ms_last_error();
    ms_client_config cc = ClientConfig(server_->address());
    cc.struct_size = 1;
    ms_client* c = nullptr;
    EXPECT_EQ(ms_client_create(&cc, &c), MS_ERR_INVALID_ARGUMENT);
    there_after = ms_last_error();
  });
  other.join();
  EXPECT_EQ(there_before, "") << "a new thread starts without an error";
  EXPECT_NE(there_after.find("config->struct_size"), std::string::npos) << there_after;
  EXPECT_EQ(ms_last_error(), here) << "the other thread's failure left this thread's error alone";
}

TEST_F(CApi, VersionAndStatusNames) {
  EXPECT_STREQ(ms_version(), MESHSTREAM_PROJECT_VERSION);
  const std::vector<std::pair<ms_status, const char*>> names = {
      {MS_OK, "MS_OK"},
      {MS_ERR_INVALID_ARGUMENT, "MS_ERR_INVALID_ARGUMENT"},
      {MS_ERR_NOT_FOUND, "MS_ERR_NOT_FOUND"},
      {MS_ERR_UNAUTHENTICATED, "MS_ERR_UNAUTHENTICATED"},
      {MS_ERR_UNAVAILABLE, "MS_ERR_UNAVAILABLE"},
      {MS_ERR_TIMEOUT, "MS_ERR_TIMEOUT"},
      {MS_ERR_INTERNAL, "MS_ERR_INTERNAL"}};
  for (size_t i = 0; i < names.size(); ++i) {
    EXPECT_EQ(static_cast<int>(names[i].first), static_cast<int>(i)) << "the contract's values";
    EXPECT_STREQ(ms_status_name(names[i].first), names[i].second);
  }
  EXPECT_STREQ(ms_status_name(static_cast<ms_status>(99)), "MS_ERR_UNKNOWN");
  EXPECT_EQ(static_cast<int>(MS_EVENT_NONE), 0);
  EXPECT_EQ(static_cast<int>(MS_EVENT_ERROR), 4);
}

TEST_F(CApi, StructSizeReadsOnlyWhatFits) {
  // A caller built against the first version: struct_size ends at `token`,
  // and what follows is not read (tls = 1 would make this session fail on a
  // plaintext server).
  struct {
    ms_client_config config;
    char tail[64];
  } old_client;
  std::memset(&old_client, 0, sizeof old_client);
  old_client.config.struct_size = MS_CLIENT_CONFIG_V0_SIZE;
  const std::string address = server_->address();
  old_client.config.server = address.c_str();
  old_client.config.tls = 1;
  old_client.config.tls_ca_pem = "not a certificate";
  old_client.config.deadline_ms = 1;  // would end the session at once if it were read
  ms_client* raw = nullptr;
  ASSERT_EQ(ms_client_create(&old_client.config, &raw), MS_OK) << ms_last_error();
  ClientPtr client(raw);
  // A caller built against a later header: more fields than we know, ignored.
  struct {
    ms_session_config config;
    int64_t future_field;
  } new_session;
  std::memset(&new_session, 0, sizeof new_session);
  new_session.config = SessionConfig("spot", 2);
  new_session.config.struct_size = sizeof new_session;
  new_session.future_field = 12345;
  ms_session* session = nullptr;
  ASSERT_EQ(ms_session_open(client.get(), &new_session.config, &session), MS_OK) << ms_last_error();
  SessionPtr owned(session);
  const auto events = PollToEnd(session);
  ASSERT_EQ(events.back().event.type, MS_EVENT_COMPLETE) << events.back().error;
  EXPECT_EQ(events.back().event.level, 2);
  // The default: a NULL server is 127.0.0.1:7600 (no connection yet).
  ms_client_config defaults = ClientConfig("");
  defaults.server = nullptr;
  ASSERT_EQ(ms_client_create(&defaults, &raw), MS_OK) << ms_last_error();
  ms_client_destroy(raw);
  // Stats write nothing past struct_size.
  struct {
    ms_stats stats;
    unsigned char guard[32];
  } out;
  std::memset(&out, 0xAB, sizeof out);
  out.stats.struct_size = MS_STATS_V0_SIZE;
  ASSERT_EQ(ms_session_stats(session, &out.stats), MS_OK) << ms_last_error();
  EXPECT_EQ(out.stats.level_shown, 2);
  EXPECT_EQ(out.stats.primitive_count, 1u);
  const unsigned char* bytes = reinterpret_cast<const unsigned char*>(&out);
  for (size_t i = sizeof(ms_stats); i < sizeof out; ++i) {
    EXPECT_EQ(bytes[i], 0xAB) << "byte " << i << " past the struct was written";
  }
  out.stats.struct_size = MS_STATS_V0_SIZE - 1;
  EXPECT_EQ(ms_session_stats(session, &out.stats), MS_ERR_INVALID_ARGUMENT);
}

TEST_F(CApi, ClientMayGoBeforeItsSessions) {
  ClientPtr client = NewClient();
  SessionPtr session = Open(client.get(), SessionConfig("spot"));
  ASSERT_NE(session, nullptr);
  client.reset();  // the connection lives on in the session
  const auto events = PollToEnd(session.get());
  ASSERT_EQ(events.back().event.type, MS_EVENT_COMPLETE) << events.back().error;
}

TEST_F(CApi, CancelEndsTheSessionAsUnavailable) {
  ClientPtr client = NewClient();
  SessionPtr session = Open(client.get(), SessionConfig("engine"));
  ASSERT_NE(session, nullptr);
  ASSERT_EQ(ms_session_cancel(session.get()), MS_OK);
  const auto events = PollToEnd(session.get());
  ASSERT_FALSE(events.empty());
  EXPECT_EQ(events.back().event.type, MS_EVENT_ERROR);
  EXPECT_EQ(events.back().returned, MS_ERR_UNAVAILABLE) << events.back().error;
  EXPECT_NE(events.back().error.find("CANCELLED"), std::string::npos) << events.back().error;
}

TEST_F(CApi, ExportWritesFilesTheImportersReadBack) {
  ClientPtr client = NewClient();
  for (const char* asset : {"spot", "engine"}) {
    SCOPED_TRACE(asset);
    SessionPtr session = Open(client.get(), SessionConfig(asset));
    const auto events = PollToEnd(session.get());
    ASSERT_EQ(events.back().event.type, MS_EVENT_COMPLETE) << events.back().error;
    const Totals totals = Sum(session.get());
    test_util::TempDir out;
    for (const char* name : {"out.glb", "out.gltf"}) {
      const std::string path = out.File(name);
      ASSERT_EQ(ms_session_export(session.get(), path.c_str()), MS_OK) << ms_last_error();
      auto scene = ImportFile(path);
      ASSERT_TRUE(scene.ok()) << scene.status().ToString();
      EXPECT_EQ(SceneVertices(*scene), totals.vertices) << name;
      EXPECT_EQ(SceneVertices(*scene), SceneVertices(Asset(asset).decoded)) << name;
    }
  }
}

// The example's lines: "level K: V vertices, F faces, P predicted, T ms",
// then "complete: ...".
// Without --tcp-only the server picks the transport (UDP once it has it):
// then neither the transport nor the predicted count is fixed.
void ExpectExampleOutput(const test_util::CommandResult& r, const Stored& stored, const std::string& out,
                         bool tcp_only) {
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::regex level_line(R"(level (\d+): (\d+) vertices, (\d+) faces, (\d+) predicted, (\d+) ms)");
  std::vector<std::string> lines;
  for (size_t start = 0; start < r.out.size();) {
    const size_t end = std::min(r.out.find('\n', start), r.out.size());
    lines.push_back(r.out.substr(start, end - start));
    start = end + 1;
  }
  // Levels decoded before the example polls come as one event for the
  // highest (the SDK decodes on its own thread): the base first, then
  // increasing levels, the last of them every level.
  const size_t levels = stored.report.levels;
  ASSERT_GE(lines.size(), 3u) << r.out;
  ASSERT_LE(lines.size(), levels + 2) << r.out;
  size_t previous = 0;
  for (size_t i = 0; i + 1 < lines.size(); ++i) {
    std::smatch m;
    ASSERT_TRUE(std::regex_match(lines[i], m, level_line)) << lines[i];
    const size_t k = std::stoul(m[1]);
    ASSERT_LE(k, levels) << lines[i];
    if (i == 0) {
      EXPECT_EQ(k, 0u) << lines[i];
    } else {
      EXPECT_GT(k, previous) << lines[i];
    }
    if (i + 2 == lines.size()) { EXPECT_EQ(k, levels) << lines[i]; }
    previous = k;
    EXPECT_EQ(std::stoul(m[2]), stored.report.level_vertices[k]) << lines[i];
    if (tcp_only) { EXPECT_EQ(std::stoul(m[4]), 0u) << lines[i]; }
  }
  const std::string expected_end = "complete: level " + std::to_string(levels) + " of " + std::to_string(levels) +
                                   ", " + std::to_string(stored.report.level_vertices.back()) + " vertices, ";
  EXPECT_EQ(lines.back().rfind(expected_end, 0), 0u) << lines.back();
  if (tcp_only) { EXPECT_NE(lines.back().find("transport grpc"), std::string::npos) << lines.back(); }
  EXPECT_NE(lines.back().find("wrote " + out), std::string::npos) << lines.back();
  auto scene = ImportFile(out);
  ASSERT_TRUE(scene.ok()) << scene.status().ToString();
  EXPECT_EQ(SceneVertices(*scene), stored.report.level_vertices.back());
}

// The usage and failure exit codes of an example binary.
void ExpectExampleFailures(const std::string& binary, const std::string& address, const std::string& run_env = "") {
  const std::string run = run_env + (run_env.empty() ? "" : " ") + Quote(binary);
  const auto usage = RunCommand(run);
  EXPECT_EQ(usage.exit_code, 2);
  EXPECT_NE(usage.err.find("usage: stream_mesh SERVER ASSET OUT.glb"), std::string::npos) << usage.err;
  EXPECT_EQ(RunCommand(run + " a b c --bogus").exit_code, 2);
  EXPECT_EQ(RunCommand(run + " a b c d").exit_code, 2);
  EXPECT_EQ(RunCommand(run + " a b c --token").exit_code, 2);
  const test_util::TempDir out;
  const auto missing = RunCommand(run + " " + address + " no-such-asset " + Quote(out.File("x.glb")));
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_NE(missing.err.find("no-such-asset"), std::string::npos) << missing.err;
  EXPECT_NE(missing.err.find("MS_ERR_NOT_FOUND"), std::string::npos) << missing.err;
  EXPECT_FALSE(std::filesystem::exists(out.File("x.glb")));
}

TEST_F(CApi, ExampleBuiltByCMakeStreamsAndExports) {
  const test_util::TempDir out;
  for (const char* transport : {" --tcp-only", ""}) {
    const std::string file = out.File(std::string("spot") + (*transport ? "-tcp" : "") + ".glb");
    const auto r = RunCommand(Quote(MESHSTREAM_C_EXAMPLE) + " " + server_->address() + " spot " + Quote(file) + transport);
    ExpectExampleOutput(r, Asset("spot"), file, *transport != '\0');
  }
  ExpectExampleFailures(MESHSTREAM_C_EXAMPLE, server_->address());
}

// Compiles the example with the system's cc and pkg-config, and runs it.
void BuildAndRunExample(const std::string& pkg_config_env, const std::string& run_env, const std::string& dir,
                        const std::string& address, const Stored& spot) {
  const std::string flags = "$(" + pkg_config_env + " pkg-config --cflags --libs meshstream)";
  const std::string binary = dir + "/stream_mesh";
  const auto cc = RunCommand("cc -std=c99 -Wall -Wextra -pedantic -Werror -o " + Quote(binary) + " " +
                             Quote(MESHSTREAM_C_EXAMPLE_SOURCE) + " " + flags);
  ASSERT_EQ(cc.exit_code, 0) << cc.out << cc.err;
  const std::string file = dir + "/spot.glb";
  ExpectExampleOutput(RunCommand(run_env + " " + Quote(binary) + " " + address + " spot " + Quote(file) + " --tcp-only"),
                      spot, file, true);
  ExpectExampleFailures(binary, address, run_env);
}

TEST_F(CApi, ExampleBuildsWithPkgConfigFromTheBuildTree) {
  const test_util::TempDir dir;
  const std::string env = "PKG_CONFIG_PATH=" + Quote(MESHSTREAM_PKG_CONFIG_PATH);
  const auto libs = RunCommand(env + " pkg-config --cflags --libs meshstream");
  ASSERT_EQ(libs.exit_code, 0) << libs.err;
  EXPECT_NE(libs.out.find("-lmeshstream"), std::string::npos) << libs.out;
  EXPECT_NE(libs.out.find("-I" + test_util::SourcePath("sdk/include")), std::string::npos) << libs.out;
  const auto version = RunCommand(env + " pkg-config --modversion meshstream");
  EXPECT_EQ(version.out, std::string(MESHSTREAM_PROJECT_VERSION) + "\n");
  // No LD_LIBRARY_PATH: the build tree's .pc carries the rpath.
  BuildAndRunExample(env, "env -u LD_LIBRARY_PATH", dir.path(), server_->address(), Asset("spot"));
}

TEST_F(CApi, ExampleBuildsWithPkgConfigFromAnInstalledTree) {
  const test_util::TempDir dir;
  const std::string prefix = dir.File("prefix");
  const auto install = RunCommand(Quote(MESHSTREAM_CMAKE) + " --install " + Quote(MESHSTREAM_BUILD_DIR) +
                                  " --component c_api --prefix " + Quote(prefix));
  ASSERT_EQ(install.exit_code, 0) << install.out << install.err;
  EXPECT_TRUE(std::filesystem::exists(prefix + "/include/meshstream/meshstream.h"));
  std::string pc_dir, lib_dir;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(prefix)) {
    const std::string name = entry.path().filename().string();
    if (name == "meshstream.pc") pc_dir = entry.path().parent_path().string();
    if (name == "libmeshstream.so.0") lib_dir = entry.path().parent_path().string();
    EXPECT_EQ(name.find("uninstalled"), std::string::npos) << "installed: " << entry.path();
  }
  ASSERT_FALSE(pc_dir.empty()) << "no meshstream.pc installed";
  ASSERT_FALSE(lib_dir.empty()) << "no libmeshstream.so.0 installed";
  EXPECT_TRUE(std::filesystem::exists(lib_dir + "/libmeshstream.so")) << "the link-time name";
  const std::string env = "PKG_CONFIG_PATH=" + Quote(pc_dir);
  const auto cflags = RunCommand(env + " pkg-config --cflags meshstream");
  ASSERT_EQ(cflags.exit_code, 0) << cflags.err;
  ASSERT_EQ(cflags.out.rfind("-I", 0), 0u) << cflags.out;
  std::string include = cflags.out.substr(2);
  while (!include.empty() && (include.back() == '\n' || include.back() == ' ')) include.pop_back();
  EXPECT_EQ(std::filesystem::weakly_canonical(include), std::filesystem::weakly_canonical(prefix + "/include"))
      << "relocated to the prefix: " << cflags.out;
  BuildAndRunExample(env, "LD_LIBRARY_PATH=" + Quote(lib_dir), dir.path(), server_->address(), Asset("spot"));
  // It ran against the installed library, not the build tree's.
  const auto ldd = RunCommand("LD_LIBRARY_PATH=" + Quote(lib_dir) + " ldd " + Quote(dir.File("stream_mesh")));
  EXPECT_NE(ldd.out.find(lib_dir + "/libmeshstream.so.0"), std::string::npos) << ldd.out;
}

// `make install`'s two components into a prefix: the CLI, and the C API's
// static archive, which an engine links with `pkg-config meshstream-static`
// alone (the example then has no libmeshstream.so to load).
TEST_F(CApi, ExampleLinksStaticallyFromAnInstalledTree) {
  const test_util::TempDir dir;
  const std::string prefix = dir.File("prefix");
  for (const char* component : {"cli", "c_api"}) {
    const auto install = RunCommand(Quote(MESHSTREAM_CMAKE) + " --install " + Quote(MESHSTREAM_BUILD_DIR) +
                                    " --component " + component + " --prefix " + Quote(prefix));
    ASSERT_EQ(install.exit_code, 0) << install.out << install.err;
  }
  const auto version = RunCommand(Quote(prefix + "/bin/meshstream") + " --version");
  EXPECT_EQ(version.exit_code, 0) << version.err;
  std::string pc_dir, archive;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(prefix)) {
    if (entry.path().filename() == "meshstream-static.pc") pc_dir = entry.path().parent_path().string();
    if (entry.path().filename() == "libmeshstream.a") archive = entry.path().string();
  }
  ASSERT_FALSE(pc_dir.empty()) << "no meshstream-static.pc installed";
  ASSERT_FALSE(archive.empty()) << "no libmeshstream.a installed";
  const std::string env = "PKG_CONFIG_PATH=" + Quote(pc_dir);
  const auto libs = RunCommand(env + " pkg-config --libs meshstream-static");
  ASSERT_EQ(libs.exit_code, 0) << libs.err;
  EXPECT_NE(libs.out.find("libmeshstream.a"), std::string::npos) << libs.out;
  const std::string binary = dir.File("stream_mesh_static");
  const auto cc = RunCommand("cc -std=c99 -Wall -Wextra -pedantic -Werror -o " + Quote(binary) + " " +
                             Quote(MESHSTREAM_C_EXAMPLE_SOURCE) + " $(" + env + " pkg-config --cflags --libs meshstream-static)");
  ASSERT_EQ(cc.exit_code, 0) << cc.out << cc.err;
  const auto ldd = RunCommand("ldd " + Quote(binary));
  EXPECT_EQ(ldd.out.find("libmeshstream"), std::string::npos) << ldd.out;
  const std::string file = dir.File("spot.glb");
  ExpectExampleOutput(RunCommand("env -u LD_LIBRARY_PATH " + Quote(binary) + " " + server_->address() + " spot " +
                                 Quote(file) + " --tcp-only"),
                      Asset("spot"), file, true);
  // An engine's plugin: the archive linked into a shared object of its own,
  // loaded with dlopen by a host that knows nothing of meshstream.
  const std::string plugin_c = dir.File("plugin.c"), host_c = dir.File("host.c");
  const std::string plugin = dir.File("plugin.so"), host = dir.File("host");
  const auto write = [](const std::string& path, const std::string& text) {
    return WriteFileBytes(path, std::vector<uint8_t>(text.begin(), text.end())).ok();
  };
  ASSERT_TRUE(write(plugin_c, "#include <meshstream/meshstream.h>\n"
                              "const char* plugin_version(void) { return ms_version(); }\n"));
  ASSERT_TRUE(write(host_c, "#include <dlfcn.h>\n#include <stdio.h>\n"
                                             "int main(int argc, char** argv) {\n"
                                             "  void* h = dlopen(argv[argc - 1], RTLD_NOW);\n"
                                             "  if (!h) { puts(dlerror()); return 1; }\n"
                                             "  const char* (*v)(void) = (const char* (*)(void))dlsym(h, \"plugin_version\");\n"
                                             "  if (!v) return 2;\n  puts(v());\n  return 0;\n}\n"));
  const auto shared = RunCommand("cc -std=c99 -fPIC -shared -o " + Quote(plugin) + " " + Quote(plugin_c) + " $(" + env +
                                 " pkg-config --cflags --libs meshstream-static)");
  ASSERT_EQ(shared.exit_code, 0) << "the archive must link into a shared object: " << shared.out << shared.err;
  const auto built_host = RunCommand("cc -o " + Quote(host) + " " + Quote(host_c) + " -ldl");
  ASSERT_EQ(built_host.exit_code, 0) << built_host.err;
  const auto loaded = RunCommand(Quote(host) + " " + Quote(plugin));
  EXPECT_EQ(loaded.exit_code, 0) << loaded.out << loaded.err;
  EXPECT_EQ(loaded.out, std::string(MESHSTREAM_PROJECT_VERSION) + "\n");
}

}  // namespace
}  // namespace meshstream
