// Errors of PanoScan: every failure a user can cause is an Error whose message names the
// file and the field involved. They are caught once, in main, and printed on one line.
#pragma once

#include <stdexcept>
#include <string>

namespace panoscan {

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(message) {}
};

// A stage that can tell its own result is wrong and refuses it (exit 2 like every Error; the
// house rule "a stage that can tell its result is wrong refuses"). Its own type so that a
// multi-seed record can count refusals as outcomes (tables --record-refusals) without also
// swallowing bad input.
class Refusal : public Error {
 public:
  explicit Refusal(const std::string& message) : Error(message) {}
};

// "<file>: <field>: <what>"; either part may be empty and is then left out.
Error make_error(const std::string& file, const std::string& field, const std::string& what);
Refusal make_refusal(const std::string& file, const std::string& field, const std::string& what);

}  // namespace panoscan
