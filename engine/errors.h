// Engine error types. The HTTP layer maps each type to one status code in one
// place (server), the CLI prints `what()` on one line; nothing else formats errors.
#pragma once

#include <stdexcept>
#include <string>

namespace featureline {

/// Base of every error the engine throws on purpose.
class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(message) {}
};

/// The caller's request is malformed: unknown option, key id out of range, bad value. (HTTP 400)
class InvalidInputError : public Error {
 public:
  using Error::Error;
};

/// The mesh bytes cannot be read: truncated, malformed, lying header, unsupported format. (HTTP 400/415)
class MeshFormatError : public Error {
 public:
  using Error::Error;
};

/// The format itself is not one we read. (HTTP 415)
class UnsupportedFormatError : public Error {
 public:
  using Error::Error;
};

/// A well-formed request the geometry cannot satisfy: keys in different components,
/// a key on an isolated vertex, a mesh with no usable faces. (HTTP 422)
class GeometryError : public Error {
 public:
  using Error::Error;
};

/// The caller cancelled the work, or its deadline passed, before it finished (engine/cancellation.h). (HTTP 503)
class CancelledError : public Error {
 public:
  using Error::Error;
};

/// The input exceeds a configured limit (vertex count, byte size). (HTTP 413)
class LimitExceededError : public Error {
 public:
  using Error::Error;
};

}  // namespace featureline
