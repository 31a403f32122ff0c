#include "bench/stream/server_log.h"

#include <algorithm>
#include <cstdio>

#include "bench/bench_util.h"
#include "bench/harness.h"

namespace meshstream::bench::stream {

namespace {

// The parsed "session ... ended" line; false for any other line.
bool ParseSessionLine(const std::string& line, SessionLogLine* s) {
  if (line.rfind("session ", 0) != 0) return false;
  const size_t ended = line.find(" ended (");
  const size_t close = line.find("): ", ended == std::string::npos ? 0 : ended);
  if (ended == std::string::npos || close == std::string::npos) return false;
  s->asset = line.substr(8, ended - 8);
  s->reason = line.substr(ended + 8, close - ended - 8);
  char transport[16] = {0};
  unsigned long long sent = 0, reports = 0, missing = 0;
  if (std::sscanf(line.c_str() + close + 3,
                  "%15[a-z], %llu datagrams sent, %llu reports, %llu missing, rate %lf Mbit/s, %u decreases, srtt "
                  "%lf ms",
                  transport, &sent, &reports, &missing, &s->rate_mbps, &s->decreases, &s->srtt_ms) != 7) {
    return false;
  }
  s->transport = transport;
  s->datagrams_sent = sent;
  s->reports = reports;
  s->missing = missing;
  const size_t base = line.find(", open to base ", close);
  if (base != std::string::npos && std::sscanf(line.c_str() + base, ", open to base %lf ms", &s->open_to_base_ms) != 1) {
    s->open_to_base_ms = -1;
  }
  return true;
}

}  // namespace

void ServerLog::Add(const std::string& line) {
  std::lock_guard<std::mutex> lock(mutex_);
  lines_.push_back(line);
  if (verbose_) std::fprintf(stderr, "[server] %s\n", line.c_str());
  SessionLogLine s;
  if (ParseSessionLine(line, &s)) {
    sessions_.push_back(s);
    session_added_.notify_all();
  }
}

size_t ServerLog::line_count() {
  std::lock_guard<std::mutex> lock(mutex_);
  return lines_.size();
}

size_t ServerLog::session_count() {
  std::lock_guard<std::mutex> lock(mutex_);
  return sessions_.size();
}

bool ServerLog::WaitSessions(size_t n, std::chrono::milliseconds timeout) {
  std::unique_lock<std::mutex> lock(mutex_);
  return session_added_.wait_for(lock, timeout, [&] { return sessions_.size() >= n; });
}

std::vector<SessionLogLine> ServerLog::SessionsFrom(size_t first) {
  std::lock_guard<std::mutex> lock(mutex_);
  return std::vector<SessionLogLine>(sessions_.begin() + static_cast<long>(std::min(first, sessions_.size())),
                                     sessions_.end());
}

std::string ServerLog::UdpTotalsFrom(size_t first) {
  std::lock_guard<std::mutex> lock(mutex_);
  std::string out;
  for (size_t i = first; i < lines_.size(); ++i) {
    if (lines_[i].rfind("udp: ", 0) == 0) out = lines_[i];
  }
  return out;
}

nlohmann::json ServerLog::Notable(size_t limit) {
  std::lock_guard<std::mutex> lock(mutex_);
  nlohmann::json out = nlohmann::json::array();
  for (const std::string& l : lines_) {
    const bool routine_session = l.rfind("session ", 0) == 0 && l.find(" ended (complete)") != std::string::npos;
    if (routine_session) continue;
    if (out.size() < limit) out.push_back(l);
  }
  return out;
}

ServerOptions StreamServerOptions(const Args& args, const std::string& store, ServerLog* log) {
  return BenchServerOptions(store, args.workers, "bench-stream", [log](const std::string& line) { log->Add(line); });
}

std::string StopAndTakeUdpTotals(std::unique_ptr<Server>& server, ServerLog& log) {
  const size_t before = log.line_count();
  StopServer(server);
  return log.UdpTotalsFrom(before);
}

}  // namespace meshstream::bench::stream
