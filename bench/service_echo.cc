#include "bench/service_echo.h"

#include <chrono>

#include <grpcpp/generic/async_generic_service.h>
#include <grpcpp/generic/generic_stub.h>

namespace meshstream::bench {

namespace {

// One call of either method; deletes itself when gRPC is done with it.
class EchoReactor final : public grpc::ServerGenericBidiReactor {
 public:
  explicit EchoReactor(bool sink) : sink_(sink) { StartRead(&in_); }

  void OnReadDone(bool ok) override {
    if (!ok) {  // the client half-closed (or went away)
      if (!sink_) {
        Finish(grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, "echo: no request message"));
        return;
      }
      std::string count(8, '\0');
      for (int i = 0; i < 8; ++i) count[i] = static_cast<char>((received_ >> (8 * i)) & 0xff);
      out_ = ToByteBuffer(count);
      StartWriteAndFinish(&out_, grpc::WriteOptions(), grpc::Status::OK);
      return;
    }
    if (sink_) {
      received_ += in_.Length();
      in_.Clear();
      StartRead(&in_);
      return;
    }
    out_ = in_;
    StartWriteAndFinish(&out_, grpc::WriteOptions(), grpc::Status::OK);
  }
  void OnDone() override { delete this; }

 private:
  const bool sink_;
  grpc::ByteBuffer in_, out_;
  uint64_t received_ = 0;
};

class EchoService final : public grpc::CallbackGenericService {
 public:
  grpc::ServerGenericBidiReactor* CreateReactor(grpc::GenericCallbackServerContext* context) override {
    if (context->method() == kEchoMethod) return new EchoReactor(false);
    if (context->method() == kSinkMethod) return new EchoReactor(true);
    return grpc::CallbackGenericService::CreateReactor(context);  // UNIMPLEMENTED
  }
};

bool Step(grpc::CompletionQueue& cq, intptr_t id) {
  void* tag = nullptr;
  bool ok = false;
  return cq.Next(&tag, &ok) && reinterpret_cast<intptr_t>(tag) == id && ok;
}

}  // namespace

struct EchoServer::Impl {
  EchoService service;
  std::unique_ptr<grpc::Server> server;
};

StatusOr<std::unique_ptr<EchoServer>> EchoServer::Start() {
  auto echo = std::unique_ptr<EchoServer>(new EchoServer());
  echo->impl_ = std::make_unique<Impl>();
  grpc::ServerBuilder builder;
  int port = 0;
  builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
  builder.RegisterCallbackGenericService(&echo->impl_->service);
  builder.SetMaxReceiveMessageSize(4 << 20);
  builder.SetMaxSendMessageSize(4 << 20);
  echo->impl_->server = builder.BuildAndStart();
  if (!echo->impl_->server || port == 0) return Unavailable("echo server: cannot listen on 127.0.0.1");
  echo->address_ = "127.0.0.1:" + std::to_string(port);
  return echo;
}

EchoServer::~EchoServer() {
  if (impl_ && impl_->server) {
    impl_->server->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(5));
    impl_->server->Wait();
  }
}

grpc::ByteBuffer ToByteBuffer(const std::string& bytes) {
  grpc::Slice slice(bytes);
  return grpc::ByteBuffer(&slice, 1);
}

std::string FromByteBuffer(const grpc::ByteBuffer& buffer) {
  std::vector<grpc::Slice> slices;
  std::string out;
  if (!buffer.Dump(&slices).ok()) return out;
  for (const grpc::Slice& s : slices) out.append(reinterpret_cast<const char*>(s.begin()), s.size());
  return out;
}

grpc::Status SinkStream(const std::shared_ptr<grpc::Channel>& channel, const std::vector<grpc::ByteBuffer>& messages,
                        uint64_t* received) {
  grpc::GenericStub stub(channel);
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(120));
  grpc::CompletionQueue cq;
  auto call = stub.PrepareCall(&context, kSinkMethod, &cq);
  bool ok = true;
  call->StartCall(reinterpret_cast<void*>(1));
  ok = Step(cq, 1);
  for (size_t i = 0; ok && i < messages.size(); ++i) {
    call->Write(messages[i], reinterpret_cast<void*>(2));
    ok = Step(cq, 2);
  }
  if (ok) {
    call->WritesDone(reinterpret_cast<void*>(3));
    ok = Step(cq, 3);
  }
  grpc::ByteBuffer answer;
  if (ok) {
    call->Read(&answer, reinterpret_cast<void*>(4));
    ok = Step(cq, 4);
  }
  grpc::Status status;
  call->Finish(&status, reinterpret_cast<void*>(5));
  void* tag = nullptr;
  bool finished = false;
  while (cq.Next(&tag, &finished)) {
    if (reinterpret_cast<intptr_t>(tag) == 5) break;
  }
  cq.Shutdown();
  while (cq.Next(&tag, &finished)) {
  }
  if (status.ok() && !ok) status = grpc::Status(grpc::StatusCode::INTERNAL, "sink: a step of the stream failed");
  *received = 0;
  const std::string bytes = FromByteBuffer(answer);
  if (status.ok() && bytes.size() == 8) {
    for (int i = 0; i < 8; ++i) *received |= uint64_t{static_cast<uint8_t>(bytes[i])} << (8 * i);
  }
  return status;
}

}  // namespace meshstream::bench
