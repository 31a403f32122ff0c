// The SDK's connection to a meshstream server: address, token, TLS and
// deadlines in one ClientOptions, and one gRPC channel shared by every
// session (session.h) and every AssetClient (asset_client.h) made on it.
// ClientOptions is the one description of a connection: the CLI's --server,
// --token, --tls, --tls-ca and --timeout fill it, the C API's ms_client_config
// fills it, the tests fill it.
//
// Thread safety: a Client may be used from several threads at once; it must
// outlive its sessions (an AssetClient shares ownership of it).
#ifndef MESHSTREAM_SDK_CLIENT_H_
#define MESHSTREAM_SDK_CLIENT_H_

#include <cstdint>
#include <memory>
#include <mutex>
#include <string>

#include <grpcpp/grpcpp.h>

#include "codec/core/status.h"
#include "proto/default_address.h"

namespace meshstream::sdk {

struct ClientOptions {
  std::string server = kDefaultAddress;  // HOST:PORT, [v6]:port or unix:/path
  std::string token;          // sent as `authorization: Bearer TOKEN` when not empty
  bool tls = false;
  std::string tls_ca_pem;     // roots that sign the server's certificate (PEM text); empty: the system's
  std::string tls_server_name;  // the name to check the certificate against; empty: the host of `server`
  // AssetClient's deadline for one request, in seconds: unary calls get it as
  // it is, an upload gets it per MiB (at least a minute); a watch and an
  // export have none. <= 0: no deadline.
  double request_timeout_s = 60.0;
  // A deadline on each session (Session::Open) from its open to its end, in
  // ms; 0: none. A session that has not ended in time fails with
  // kDeadlineExceeded (MS_ERR_TIMEOUT in the C API).
  int64_t session_deadline_ms = 0;
};

// The loss a client has seen on its UDP path over its last sessions: the
// raw loss (data datagrams lost / (lost + received over UDP), before any
// parity rebuilt them), each session's counts added to the earlier ones
// halved, so that the last two or three sessions weigh most and a short
// session's noise is damped. Sessions that saw fewer than kMinimum UDP data
// datagrams say too little and are not counted. Thread-safe.
class LossMemory {
 public:
  static constexpr uint64_t kMinimum = 16;
  void Add(uint64_t lost, uint64_t received_over_udp);
  // In [0, 1]; -1 before any session was counted.
  double Rate() const;

 private:
  mutable std::mutex mutex_;
  double lost_ = 0, seen_ = 0;
};

class Client {
 public:
  // InvalidArgument for an empty server or a negative deadline. Does not
  // connect: a server that cannot be reached shows at the first call.
  static StatusOr<std::unique_ptr<Client>> Create(const ClientOptions& options);

  const ClientOptions& options() const { return options_; }
  const std::shared_ptr<grpc::Channel>& channel() const { return channel_; }
  // Prepares a session's call: the token in its metadata and, when
  // session_deadline_ms is set, its deadline.
  void Authorize(grpc::ClientContext& context) const;
  // Prepares any other call: the token and a deadline `timeout_s` from now
  // (<= 0: none).
  void Prepare(grpc::ClientContext& context, double timeout_s) const;

  // The link's loss as this client's sessions saw it (LossMemory; -1
  // before any). A session opened without expected_loss states it to the
  // server (docs/design/loss-protection.md), which sizes parity and the reliable
  // cut by it until the session's own reports take over: a clean link gets
  // no parity from the first datagram, a lossy one gets it before its first
  // loss is reported. Shared with the client's sessions (it outlives the
  // client while one of them runs).
  double remembered_loss() const { return loss_memory_->Rate(); }
  const std::shared_ptr<LossMemory>& loss_memory() const { return loss_memory_; }

 private:
  Client(ClientOptions options, std::shared_ptr<grpc::Channel> channel)
      : options_(std::move(options)), channel_(std::move(channel)) {}
  ClientOptions options_;
  std::shared_ptr<grpc::Channel> channel_;
  std::shared_ptr<LossMemory> loss_memory_ = std::make_shared<LossMemory>();
};

}  // namespace meshstream::sdk

#endif  // MESHSTREAM_SDK_CLIENT_H_
