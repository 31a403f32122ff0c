#include "bench/service_load.h"

#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <sstream>
#include <condition_variable>
#include <mutex>
#include <thread>

#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>

#include "bench/service_echo.h"

namespace meshstream::bench {

namespace {

using Clock = std::chrono::steady_clock;

// One unary call; "" when it succeeded and its response passed the check.
std::string CallOnce(grpc::GenericStub& stub, grpc::CompletionQueue& cq, const UnaryTarget& target,
                     const grpc::ByteBuffer& request, size_t index) {
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
  auto call = stub.PrepareUnaryCall(&context, target.method, request, &cq);
  call->StartCall();
  grpc::ByteBuffer response;
  grpc::Status status;
  call->Finish(&response, &status, reinterpret_cast<void*>(1));
  void* tag = nullptr;
  bool ok = false;
  if (!cq.Next(&tag, &ok) || !ok) return "the completion queue failed";
  if (!status.ok()) return "status " + std::to_string(status.error_code()) + ": " + status.error_message();
  return target.check ? target.check(index, FromByteBuffer(response)) : std::string();
}

}  // namespace

LoadResult RunLoad(const UnaryTarget& target, int clients, int calls_per_client, int warmup_calls) {
  LoadResult result;
  result.clients = clients;
  result.calls_per_client = calls_per_client;
  std::vector<grpc::ByteBuffer> requests;
  for (const std::string& r : target.requests) requests.push_back(ToByteBuffer(r));

  std::mutex mutex;
  std::condition_variable cv;
  int ready = 0;
  bool go = false;
  Clock::time_point start;
  std::vector<Clock::time_point> ends(static_cast<size_t>(clients));
  std::vector<std::vector<double>> latencies(static_cast<size_t>(clients));
  std::vector<uint64_t> failed(static_cast<size_t>(clients), 0), warmup_failed(static_cast<size_t>(clients), 0);
  std::vector<std::string> errors(static_cast<size_t>(clients));

  auto client = [&](int c) {
    grpc::ChannelArguments args;
    args.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);  // a connection of its own
    args.SetMaxReceiveMessageSize(16 << 20);
    auto channel = grpc::CreateCustomChannel(target.address, grpc::InsecureChannelCredentials(), args);
    grpc::GenericStub stub(channel);
    grpc::CompletionQueue cq;
    std::vector<grpc::ByteBuffer> mine = requests;  // references the same slices
    const size_t n = mine.size();
    for (int j = 0; j < warmup_calls; ++j) {
      const size_t index = (static_cast<size_t>(c) + static_cast<size_t>(j)) % n;
      if (!CallOnce(stub, cq, target, mine[index], index).empty()) ++warmup_failed[static_cast<size_t>(c)];
    }
    std::vector<double>& lat = latencies[static_cast<size_t>(c)];
    lat.reserve(static_cast<size_t>(calls_per_client));
    {
      std::unique_lock<std::mutex> lock(mutex);
      ++ready;
      cv.notify_all();
      cv.wait(lock, [&] { return go; });
    }
    for (int j = 0; j < calls_per_client; ++j) {
      const size_t index = (static_cast<size_t>(c) + static_cast<size_t>(j)) % n;
      const auto t0 = Clock::now();
      const std::string error = CallOnce(stub, cq, target, mine[index], index);
      const auto t1 = Clock::now();
      if (error.empty()) {
        lat.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
      } else {
        ++failed[static_cast<size_t>(c)];
        if (errors[static_cast<size_t>(c)].empty()) errors[static_cast<size_t>(c)] = error;
      }
    }
    ends[static_cast<size_t>(c)] = Clock::now();
    cq.Shutdown();
    void* tag = nullptr;
    bool ok = false;
    while (cq.Next(&tag, &ok)) {
    }
  };

  std::vector<std::thread> threads;
  threads.reserve(static_cast<size_t>(clients));
  for (int c = 0; c < clients; ++c) threads.emplace_back(client, c);
  {
    std::unique_lock<std::mutex> lock(mutex);
    cv.wait(lock, [&] { return ready == clients; });
    start = Clock::now();
    go = true;
  }
  const CpuSample before = SampleCpu();
  cv.notify_all();
  for (std::thread& t : threads) t.join();
  const CpuSample after = SampleCpu();
  result.process_cpu_s = after.process_s - before.process_s;
  result.machine_busy = after.machine_busy - before.machine_busy;
  result.machine_total = after.machine_total - before.machine_total;

  Clock::time_point last = start;
  for (int c = 0; c < clients; ++c) {
    const size_t i = static_cast<size_t>(c);
    last = std::max(last, ends[i]);
    result.latencies_us.insert(result.latencies_us.end(), latencies[i].begin(), latencies[i].end());
    result.failed += failed[i];
    result.warmup_failed += warmup_failed[i];
    if (result.first_error.empty() && !errors[i].empty()) result.first_error = errors[i];
  }
  result.wall_s = std::chrono::duration<double>(last - start).count();
  return result;
}

CpuSample SampleCpu() {
  CpuSample s;
  rusage usage{};
  if (getrusage(RUSAGE_SELF, &usage) == 0) {
    s.process_s = static_cast<double>(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
                  static_cast<double>(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec) / 1e6;
  }
  std::ifstream stat("/proc/stat");
  std::string line;
  if (std::getline(stat, line)) {
    std::istringstream in(line);
    std::string cpu;
    in >> cpu;  // "cpu": the sum over all cores
    uint64_t v[8] = {0};
    for (uint64_t& x : v) in >> x;  // user nice system idle iowait irq softirq steal
    s.machine_total = v[0] + v[1] + v[2] + v[3] + v[4] + v[5] + v[6] + v[7];
    s.machine_busy = s.machine_total - v[3] - v[4];
  }
  return s;
}

}  // namespace meshstream::bench
