// Probes of the standard gRPC services a server offers, through
// grpc::GenericStub (calls by method name, so no generated code is needed): grpc.health.v1.Health/Check and
// grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo. The two
// messages are encoded by hand: HealthCheckRequest{service} is field 1
// (string), HealthCheckResponse{status} field 1 (varint, SERVING = 1,
// NOT_SERVING = 2); ServerReflectionRequest{list_services} is field 7.
#ifndef MESHSTREAM_TESTING_GRPC_PROBE_H_
#define MESHSTREAM_TESTING_GRPC_PROBE_H_

#include <chrono>
#include <future>
#include <memory>
#include <string>
#include <vector>

#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>
#include <grpcpp/support/byte_buffer.h>

namespace meshstream::test_util {

inline grpc::ByteBuffer ToBuffer(const std::string& bytes) {
  grpc::Slice slice(bytes);
  return grpc::ByteBuffer(&slice, 1);
}

inline std::string FromBuffer(const grpc::ByteBuffer& buffer) {
  std::vector<grpc::Slice> slices;
  std::string out;
  if (!buffer.Dump(&slices).ok()) return out;
  for (const grpc::Slice& s : slices) out.append(reinterpret_cast<const char*>(s.begin()), s.size());
  return out;
}

struct HealthAnswer {
  grpc::Status status;
  int serving_status = 0;  // 1 SERVING, 2 NOT_SERVING
};

inline HealthAnswer CheckHealth(const std::shared_ptr<grpc::Channel>& channel, const std::string& service = "") {
  grpc::GenericStub stub(channel);
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  std::string request;
  if (!service.empty()) {
    request.push_back(0x0a);
    request.push_back(static_cast<char>(service.size()));
    request += service;
  }
  grpc::ByteBuffer in = ToBuffer(request), out;
  std::promise<grpc::Status> done;
  stub.UnaryCall(&context, "/grpc.health.v1.Health/Check", grpc::StubOptions(), &in, &out,
                 [&done](grpc::Status s) { done.set_value(s); });
  HealthAnswer answer;
  answer.status = done.get_future().get();
  if (answer.status.ok()) {
    const std::string bytes = FromBuffer(out);
    answer.serving_status = bytes.size() >= 2 && bytes[0] == 0x08 ? bytes[1] : 0;
  }
  return answer;
}

// The reflection service's list of services, as raw response bytes (empty
// with the call's error when reflection is off).
inline std::pair<grpc::Status, std::string> ListServicesByReflection(const std::shared_ptr<grpc::Channel>& channel) {
  grpc::GenericStub stub(channel);
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  grpc::CompletionQueue cq;
  auto call = stub.PrepareCall(&context, "/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo", &cq);
  void* tag = nullptr;
  bool ok = false;
  auto step = [&](intptr_t id) {
    return cq.Next(&tag, &ok) && reinterpret_cast<intptr_t>(tag) == id && ok;
  };
  call->StartCall(reinterpret_cast<void*>(1));
  std::string response;
  if (step(1)) {
    call->Write(ToBuffer(std::string("\x3a\x00", 2)), reinterpret_cast<void*>(2));
    if (step(2)) {
      call->WritesDone(reinterpret_cast<void*>(3));
      if (step(3)) {
        grpc::ByteBuffer out;
        call->Read(&out, reinterpret_cast<void*>(4));
        if (step(4)) response = FromBuffer(out);
      }
    }
  }
  grpc::Status status;
  call->Finish(&status, reinterpret_cast<void*>(5));
  while (cq.Next(&tag, &ok)) {
    if (reinterpret_cast<intptr_t>(tag) == 5) break;
  }
  cq.Shutdown();
  while (cq.Next(&tag, &ok)) {
  }
  return {status, response};
}

}  // namespace meshstream::test_util

#endif  // MESHSTREAM_TESTING_GRPC_PROBE_H_
