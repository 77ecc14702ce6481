#pragma once
// The core tests' check that a boundary rejects its input by name: the call throws std::invalid_argument whose
// message holds the given text (a field's or argument's name), not merely some exception.

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

namespace mfot::test {

// Calls construct_or_call(); records a failure unless it throws std::invalid_argument whose what() holds text.
template <class Call>
void expect_invalid_argument(Call&& construct_or_call, const std::string& text) {
  try {
    construct_or_call();
    ADD_FAILURE() << "no std::invalid_argument; expected one saying: " << text;
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(text), std::string::npos) << e.what();
  }
}

}  // namespace mfot::test
