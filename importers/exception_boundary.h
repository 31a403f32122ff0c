// The exception boundary of importers/: the one place where an exception
// from a library (nlohmann-json, OpenMesh, tinyobjloader, tinygltf, Draco) or
// from the standard library (std::bad_alloc, std::length_error) becomes a
// Status. Every public entry point of importers/ that calls such code runs
// its body through CatchExceptions, so nothing is ever thrown past it.
//
// Contract: CatchExceptions(where, body) returns what `body` returns (a
// Status or a StatusOr<T>); an exception becomes ResourceExhausted for
// std::bad_alloc and Internal otherwise, its message prefixed by `where`.
// Thread safety: as `body`.
#ifndef MESHSTREAM_IMPORTERS_EXCEPTION_BOUNDARY_H_
#define MESHSTREAM_IMPORTERS_EXCEPTION_BOUNDARY_H_

#include <exception>
#include <new>
#include <string>

#include "codec/core/status.h"

namespace meshstream {

template <typename Body>
auto CatchExceptions(const std::string& where, Body&& body) -> decltype(body()) {
  try {
    return body();
  } catch (const std::bad_alloc&) {
    return ResourceExhausted(where + ": out of memory");
  } catch (const std::exception& e) {
    return Internal(where + ": " + e.what());
  } catch (...) {
    return Internal(where + ": unknown exception");
  }
}

}  // namespace meshstream

#endif  // MESHSTREAM_IMPORTERS_EXCEPTION_BOUNDARY_H_
