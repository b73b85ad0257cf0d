// The enum name tables now live in model/enum_names.h; this header keeps the estimation spelling
// (estimation::enum_to_string, ...) for its users.
#pragma once

#include "model/enum_names.h"

namespace sigmaheart::estimation {

using model::enum_from_string;
using model::enum_to_string;
using model::EnumName;

}  // namespace sigmaheart::estimation
