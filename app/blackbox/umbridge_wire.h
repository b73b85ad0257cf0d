// What our UM-Bridge server and client share on the wire (protocol 1.0; Seelinger et al. 2023,
// JOSS 8:4748, and the reference implementation's error types: um-bridge-benchmarks.readthedocs.io
// "Protocol"): the version, the standard error types and the JSON bodies of errors.
#pragma once

#include "model/simulator.h"

#include <nlohmann/json.hpp>

#include <optional>
#include <string>

namespace sigmaheart::app::blackbox::wire {

inline constexpr double kProtocolVersion = 1.0;

// The protocol's error types. A run of our model that fails is InvalidOutput (HTTP 500: the
// model could not produce its output) with the message "<status code>: <message>", which our
// client turns back into that Status.
inline constexpr const char* kInvalidInput = "InvalidInput";
inline constexpr const char* kInvalidOutput = "InvalidOutput";
inline constexpr const char* kModelNotFound = "ModelNotFound";
inline constexpr const char* kUnsupportedFeature = "UnsupportedFeature";

nlohmann::json error_body(const std::string& type, const std::string& message);

// "<status code name>: <message>".
std::string status_message(const model::Status& status);
// The StatusCode a status_message() starts with, and the rest of the message.
std::optional<model::StatusCode> parse_status_message(const std::string& message, std::string& rest);

// A request or reply body as a JSON object; `problem` says why not (with the byte offset, and a
// note when the text holds NaN or Infinity, which JSON cannot carry).
nlohmann::json parse_body(const std::string& text, std::string& problem);

}  // namespace sigmaheart::app::blackbox::wire
