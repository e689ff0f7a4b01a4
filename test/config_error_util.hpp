#pragma once
/// \file
/// Checks for tests of bad input: the code throws ConfigError with the expected key, or another
/// exception type, and its message holds the expected words. Checking the key and the words (not
/// only the exception type) makes a test fail when the rule it names is deleted and some later
/// rule happens to reject the same input.

#include <gtest/gtest.h>

#include <functional>
#include <string>
#include <string_view>

#include "quadtune/common/error.hpp"

namespace quadtune::test {

/// Success when `f` throws ConfigError whose key() equals `key` and whose what() contains every
/// entry of `words`; a failure naming what was thrown otherwise.
inline ::testing::AssertionResult ThrowsConfigError(const std::function<void()>& f,
                                                    std::string_view key,
                                                    std::initializer_list<std::string_view> words) {
  try {
    f();
  } catch (const ConfigError& e) {
    const std::string what = e.what();
    if (e.key() != key) {
      return ::testing::AssertionFailure()
             << "ConfigError key '" << e.key() << "', expected '" << key << "': " << what;
    }
    for (std::string_view w : words) {
      if (what.find(w) == std::string::npos) {
        return ::testing::AssertionFailure() << "ConfigError message lacks '" << w << "': " << what;
      }
    }
    return ::testing::AssertionSuccess();
  } catch (const std::exception& e) {
    return ::testing::AssertionFailure() << "threw another exception: " << e.what();
  }
  return ::testing::AssertionFailure() << "nothing thrown";
}

/// Success when `f` throws an E (or a type derived from it) whose what() contains every entry of
/// `words`; a failure naming what was thrown otherwise. For errors without a key
/// (std::invalid_argument from a function's precondition check).
template <typename E>
::testing::AssertionResult ThrowsWithMessage(const std::function<void()>& f,
                                             std::initializer_list<std::string_view> words) {
  try {
    f();
  } catch (const E& e) {
    const std::string what = e.what();
    for (std::string_view w : words) {
      if (what.find(w) == std::string::npos) {
        return ::testing::AssertionFailure() << "message lacks '" << w << "': " << what;
      }
    }
    return ::testing::AssertionSuccess();
  } catch (const std::exception& e) {
    return ::testing::AssertionFailure() << "threw another exception: " << e.what();
  }
  return ::testing::AssertionFailure() << "nothing thrown";
}

}  // namespace quadtune::test
