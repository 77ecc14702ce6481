#pragma once
// An lcm-gen message as the bytes that travel, for tests that feed handlers what LCM delivers.

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

namespace mfot::service::testing {

using Bytes = std::vector<std::uint8_t>;

template <class T>
Bytes encode(const T& message) {
  Bytes bytes(static_cast<std::size_t>(message.getEncodedSize()));
  EXPECT_EQ(message.encode(bytes.data(), 0, static_cast<int>(bytes.size())), static_cast<int>(bytes.size()));
  return bytes;
}

}  // namespace mfot::service::testing
