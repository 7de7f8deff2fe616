#pragma once
/// @file The jobs' one error of their own: a request that cannot be carried out as written.

#include "mlp/base/input_error.h"

namespace mlp::jobs {

/// A request that cannot be carried out as written: the message names the field.
class RequestError : public base::InputError {
 public:
  using base::InputError::InputError;
};

}  // namespace mlp::jobs
