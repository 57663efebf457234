#pragma once
// SHA-256 (FIPS 180-4) and HMAC-SHA256 (RFC 2104), written for ftid's command authentication
// (docs/operations.md, "Network and commands"). No library already linked into ftid provides
// them (LCM, Eigen, KDL, urdfdom, NLopt, yaml-cpp do not); OpenSSL would be a new runtime
// dependency of ftidd for 150 lines of well-specified code that is checked here against the
// FIPS 180 and RFC 4231 test vectors (test/unit/transport/hmac_test.cpp).
// No allocation, no exceptions: usable anywhere.
#include <array>
#include <cstddef>
#include <cstdint>

namespace ftid::transport {

using Sha256Digest = std::array<std::uint8_t, 32>;

class Sha256 {
 public:
  Sha256() noexcept { reset(); }
  void reset() noexcept;
  void update(const void* data, std::size_t size) noexcept;
  Sha256Digest finish() noexcept;  ///< the digest; the object must be reset() before reuse

 private:
  void block(const std::uint8_t* p) noexcept;
  std::uint32_t h_[8]{};
  std::uint8_t buf_[64]{};
  std::size_t buf_len_ = 0;
  std::uint64_t total_ = 0;
};

Sha256Digest sha256(const void* data, std::size_t size) noexcept;

/// HMAC-SHA256 with a key of any length, computed incrementally.
class HmacSha256 {
 public:
  HmacSha256(const void* key, std::size_t key_size) noexcept;
  void update(const void* data, std::size_t size) noexcept { inner_.update(data, size); }
  Sha256Digest finish() noexcept;

 private:
  Sha256 inner_;
  std::uint8_t opad_key_[64]{};
};

Sha256Digest hmacSha256(const void* key, std::size_t key_size, const void* data,
                        std::size_t size) noexcept;

/// Constant-time comparison of two digests (no early exit on the first difference).
bool digestEqual(const std::uint8_t* a, const std::uint8_t* b, std::size_t size) noexcept;

}  // namespace ftid::transport
