#pragma once
/// @file Error types shared by every module. Library code throws; only `main` exits.

#include <stdexcept>
#include <string>

namespace isoforge {

/// A file could not be read or written, or its content is not what its format requires.
/// The message names the file and, where known, the position (line:column or byte offset)
/// and what was expected there.
struct IoError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

/// A request that is well-formed but cannot be honoured (for example one that would need
/// more memory than the machine has); the message says why and what it would cost.
struct ResourceError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

}  // namespace isoforge

namespace isoforge {

/// Malformed text (a scene, an expression, a .vm model): the message carries file:line:column (or
/// the column of an expression) and what was expected there.
struct ParseError : IoError {
    using IoError::IoError;
};

}  // namespace isoforge
