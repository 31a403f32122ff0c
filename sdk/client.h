// The SDK's connection to a meshstream server: address, token and TLS, one
// gRPC channel shared by every session opened on it.
//
// Thread safety: a Client may be used from several threads at once; it must
// outlive its sessions.
#ifndef MESHSTREAM_SDK_CLIENT_H_
#define MESHSTREAM_SDK_CLIENT_H_

#include <memory>
#include <string>

#include <grpcpp/grpcpp.h>

#include "codec/core/status.h"

namespace meshstream::sdk {

struct ClientOptions {
  std::string server = "127.0.0.1:7600";
  std::string token;          // sent as `authorization: Bearer TOKEN` when not empty
  bool tls = false;
  std::string tls_ca_pem;     // roots that sign the server's certificate (PEM text); empty: the system's
};

class Client {
 public:
  static StatusOr<std::unique_ptr<Client>> Create(const ClientOptions& options);

  const ClientOptions& options() const { return options_; }
  const std::shared_ptr<grpc::Channel>& channel() const { return channel_; }
  // Adds the token to a call's metadata.
  void Authorize(grpc::ClientContext& context) const;

 private:
  Client(ClientOptions options, std::shared_ptr<grpc::Channel> channel)
      : options_(std::move(options)), channel_(std::move(channel)) {}
  ClientOptions options_;
  std::shared_ptr<grpc::Channel> channel_;
};

}  // namespace meshstream::sdk

#endif  // MESHSTREAM_SDK_CLIENT_H_
