// Memory the engine keeps between requests outside any prepared mesh: per-thread scratch of the
// stages that touch a small part of a large mesh (stamped maps, path-search labels), sized to
// the largest mesh each thread has worked on so that a request costs what it visits, not the
// mesh's size. Its bytes are counted here so that a cache budget can include them.
#pragma once

#include <cstddef>

namespace featureline {

/// Bytes held by every thread's engine scratch right now.
std::size_t engine_scratch_bytes();

/// Records a change of `delta` bytes in some thread's scratch (engine/internal only).
void account_scratch_bytes(std::ptrdiff_t delta);

}  // namespace featureline
