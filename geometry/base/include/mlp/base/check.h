#pragma once
/// @file The one precondition check (docs/DEVELOPING.md, "Errors"). A failed check is a bug in
/// the caller, never bad input: input is validated where it enters and refused with the
/// module's typed error. MLP_CHECK throws CheckFailure (a std::logic_error) naming file:line,
/// the expression and, for the comparing forms, both values; the service's job boundary turns
/// it into a refused job instead of a crashed host.

#include <sstream>
#include <stdexcept>
#include <string>

namespace mlp::base {

class CheckFailure : public std::logic_error {
 public:
  using std::logic_error::logic_error;
};

[[noreturn]] void FailCheck(const char* file,
                            int line,
                            const char* expression,
                            const std::string& detail);

/// "a = 3, b = 2": the values of a failed comparison.
template <class A, class B>
std::string CheckValues(const char* a_text, const A& a, const char* b_text, const B& b) {
  std::ostringstream s;
  s.precision(17);
  s << a_text << " = " << a << ", " << b_text << " = " << b;
  return s.str();
}

}  // namespace mlp::base

#define MLP_CHECK(condition)                                                      \
  do {                                                                            \
    if (!(condition)) ::mlp::base::FailCheck(__FILE__, __LINE__, #condition, {}); \
  } while (false)

/// MLP_CHECK with a sentence for the reader of the message.
#define MLP_CHECK_MSG(condition, message)                                              \
  do {                                                                                 \
    if (!(condition)) ::mlp::base::FailCheck(__FILE__, __LINE__, #condition, message); \
  } while (false)

#define MLP_CHECK_OP_(a, op, b)                                                             \
  do {                                                                                      \
    const auto& mlp_check_a_ = (a);                                                         \
    const auto& mlp_check_b_ = (b);                                                         \
    if (!(mlp_check_a_ op mlp_check_b_))                                                    \
      ::mlp::base::FailCheck(__FILE__, __LINE__, #a " " #op " " #b,                         \
                             ::mlp::base::CheckValues(#a, mlp_check_a_, #b, mlp_check_b_)); \
  } while (false)

#define MLP_CHECK_EQ(a, b) MLP_CHECK_OP_(a, ==, b)
#define MLP_CHECK_NE(a, b) MLP_CHECK_OP_(a, !=, b)
#define MLP_CHECK_LT(a, b) MLP_CHECK_OP_(a, <, b)
#define MLP_CHECK_LE(a, b) MLP_CHECK_OP_(a, <=, b)
#define MLP_CHECK_GT(a, b) MLP_CHECK_OP_(a, >, b)
#define MLP_CHECK_GE(a, b) MLP_CHECK_OP_(a, >=, b)
