#include "mlp/host/job_command.h"

#include "mlp/host/cli.h"
#include "mlp/service/job_client.h"
#include "mlp/service/request_json.h"

#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>

namespace mlp::host {
namespace {

using json = nlohmann::json;
constexpr const char* kDefaultSocket = "/run/mlprobe/jobs.sock";
constexpr int kStatusTimeoutMs = 5000;
constexpr double kDefaultRequestTimeoutS = 600;

struct Options {
  std::string socket, file;
  double timeout_s = kDefaultRequestTimeoutS;
  bool json = false;
};

Options Parse(const std::vector<std::string>& args, bool takes_file) {
  const Args a(args, {{"--socket", "--timeout"}, {"--json"}, {}, takes_file});
  Options o;
  o.socket = a.Text("--socket", "");
  o.json = a.Has("--json");
  o.timeout_s = a.Number("--timeout", o.timeout_s);
  if (!(o.timeout_s > 0) || o.timeout_s > 86400) throw UsageError("--timeout is seconds, > 0");
  if (o.socket.empty()) {
    const char* env = std::getenv("MLP_SOCKET");
    o.socket = env && *env ? env : kDefaultSocket;
  }
  if (takes_file && a.Positionals().size() != 1)
    throw UsageError("one request file (or - for stdin) is needed");
  if (takes_file) o.file = a.Positionals().front();
  return o;
}

void PrintStatus(const json& s, std::ostream& out) {
  out << "mlp-hostd up " << std::fixed << std::setprecision(0) << s.value("uptime_s", 0.0)
      << " s, probe link port " << s.value("probe_link_port", 0) << "\n";
  for (const auto& p : s.value("probes", json::array())) {
    out << "  probe " << p.value("serial", "?") << ": "
        << (p.value("connected", false) ? "connected" : "not connected");
    if (p.contains("battery_percent"))
      out << ", battery " << p.at("battery_percent").get<int>() << " %, " << std::setprecision(1)
          << p.value("temperature_c", 0.0) << " C, buffer " << p.value("buffer_used", 0) << "/"
          << p.value("buffer_capacity", 0) << ", frames dropped " << p.value("frames_dropped", 0)
          << (p.value("last_error", "").empty() ? "" : ", last error " + p.value("last_error", ""));
    out << "\n";
  }
  for (const auto& m : s.value("machines", json::array())) {
    const std::string running = m.value("running", "");
    out << "  machine " << m.value("name", "?") << " (probe " << m.value("probe", "?")
        << "): " << (running.empty() ? "idle" : "running " + running) << "\n";
  }
  if (const json& q = s.value("mqtt", json()); q.is_object()) {
    out << "  plant feed (MQTT): " << (q.value("connected", false) ? "connected" : "NOT connected")
        << ", " << q.value("published", 0) << " sent, " << q.value("queued", 0) << " held, "
        << q.value("dropped", 0) << " dropped";
    if (!q.value("last_error", "").empty()) out << ", last error: " << q.value("last_error", "");
    out << "\n";
  }
  if (const json& d = s.value("plant_database", json()); d.is_object()) {
    out << "  plant database: " << (d.value("connected", false) ? "reached" : "NOT reached") << ", "
        << d.value("sent", 0) << " jobs sent, " << d.value("waiting", 0)
        << " waiting in the outbox";
    if (!d.value("last_error", "").empty()) out << ", last error: " << d.value("last_error", "");
    out << "\n";
  }
}

// The request file's text, or stdin's; refused unread beyond what the host would take (a file of
// gigabytes must not fill the client's memory before the host refuses it).
std::string ReadRequestText(const std::string& file) {
  std::ifstream in;
  if (file != "-") {
    in.open(file, std::ios::binary);
    if (!in) throw UsageError("cannot read " + file);
  }
  std::istream& from = file == "-" ? std::cin : in;
  std::string text(service::kMaxRequestBytes + 1, '\0');
  from.read(text.data(), static_cast<std::streamsize>(text.size()));
  text.resize(static_cast<std::size_t>(from.gcount()));
  if (text.size() > service::kMaxRequestBytes)
    throw UsageError(file + " is longer than " + std::to_string(service::kMaxRequestBytes) +
                     " bytes: not a request");
  return text;
}

template <class F>
int Guarded(const char* usage, std::ostream& err, F f) {
  try {
    return f();
  } catch (const UsageError& e) {
    err << "mlp: " << e.what() << "\n" << usage;
    return kExitBadInput;
  } catch (const std::exception& e) {
    err << "mlp: " << e.what() << "\n";
    return kExitJobFailed;
  }
}

}  // namespace

int RunStatusCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  return Guarded("usage: mlp status [--socket PATH] [--json]\n", err, [&]() -> int {
    const Options o = Parse(args, false);
    const json s = service::SendRequest(o.socket, {{"op", "status"}}, kStatusTimeoutMs);
    if (o.json)
      out << service::DumpSafe(s, 2) << "\n";
    else
      PrintStatus(s, out);
    return kExitOk;
  });
}

int RunRequestCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  return Guarded("usage: mlp request [--socket PATH] [--timeout S] FILE|-\n", err, [&]() -> int {
    const Options o = Parse(args, true);
    json request;
    try {
      request = service::ParseRequest(ReadRequestText(o.file));
    } catch (const service::RequestParseError& e) {
      throw UsageError(o.file + ": " + e.what());
    }
    const json reply =
        service::SendRequest(o.socket, request, static_cast<int>(o.timeout_s * 1000));
    out << service::DumpSafe(reply, 2) << "\n";
    const std::string status = reply.value("status", "");
    if (reply.contains("error")) err << "mlp: " << reply.at("error").get<std::string>() << "\n";
    if (status == "out_of_tolerance") return kExitOutOfTolerance;
    if (status == "refused") return kExitRefused;
    if (reply.value("ok", false)) return kExitOk;
    return kExitJobFailed;
  });
}

}  // namespace mlp::host
