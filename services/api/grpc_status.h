// The Status <-> grpc::Status mapping lives in proto/rpc_status.h (one copy
// for servers and clients). This header only forwards to it for the files
// that still include it by this name (stream_service.cc); include
// proto/rpc_status.h instead.
#ifndef MESHSTREAM_SERVICES_API_GRPC_STATUS_H_
#define MESHSTREAM_SERVICES_API_GRPC_STATUS_H_

#include "proto/rpc_status.h"

#endif  // MESHSTREAM_SERVICES_API_GRPC_STATUS_H_
