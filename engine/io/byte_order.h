// Fixed-width numbers stored in a given byte order (binary PLY, STL, GLB, glTF buffers), read
// from unaligned bytes whatever the host's own byte order.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <type_traits>

namespace featureline::detail {

enum class ByteOrder { little_endian, big_endian };

/// The value of type T (an integer or floating-point type) stored at `bytes` in `order`.
template <typename T>
T load(const unsigned char* bytes, ByteOrder order) {
  static_assert(std::is_arithmetic_v<T> && (sizeof(T) == 1 || sizeof(T) == 2 || sizeof(T) == 4 || sizeof(T) == 8));
  using Bits = std::conditional_t<sizeof(T) == 1, std::uint8_t,
               std::conditional_t<sizeof(T) == 2, std::uint16_t,
               std::conditional_t<sizeof(T) == 4, std::uint32_t, std::uint64_t>>>;
  // Assembling the bits arithmetically makes the result independent of the host's byte order.
  Bits bits = 0;
  for (std::size_t i = 0; i < sizeof(T); ++i) {
    const std::size_t at = order == ByteOrder::little_endian ? i : sizeof(T) - 1 - i;
    bits = static_cast<Bits>(bits | (static_cast<Bits>(bytes[at]) << (8 * i)));
  }
  T value;
  std::memcpy(&value, &bits, sizeof value);
  return value;
}

template <typename T>
T load_little_endian(const unsigned char* bytes) {
  return load<T>(bytes, ByteOrder::little_endian);
}

template <typename T>
T load_little_endian(const char* bytes) {
  return load<T>(reinterpret_cast<const unsigned char*>(bytes), ByteOrder::little_endian);
}

}  // namespace featureline::detail
