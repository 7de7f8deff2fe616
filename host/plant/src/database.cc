#include "mlp/plant/database.h"

#include "mlp/base/json_text.h"

#include <algorithm>
#include <cctype>
#include <optional>
#include <regex>
#include <string>
#include <vector>

#include <poll.h>
#include <pqxx/pqxx>
#include <sys/socket.h>

namespace mlp::plant {
namespace {

using json = nlohmann::json;

// The tables of a host's history (history.cc), keyed by host as well; JSON as jsonb. Children
// go with their job (ON DELETE CASCADE): a job sent again replaces them whole.
constexpr const char* kSchema = R"sql(
CREATE TABLE IF NOT EXISTS mlp_meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
INSERT INTO mlp_meta VALUES ('schema_version', '1') ON CONFLICT (key) DO NOTHING;
CREATE TABLE IF NOT EXISTS jobs (
  host TEXT NOT NULL, id BIGINT NOT NULL,
  machine TEXT NOT NULL, kind TEXT NOT NULL, probe_serial TEXT NOT NULL,
  calibration_id TEXT NOT NULL, request JSONB NOT NULL, status TEXT NOT NULL,
  reply JSONB, timings_ms JSONB, started_utc TEXT NOT NULL, finished_utc TEXT,
  received_utc TIMESTAMPTZ NOT NULL DEFAULT now(),
  PRIMARY KEY (host, id));
CREATE INDEX IF NOT EXISTS jobs_started ON jobs (started_utc);
CREATE TABLE IF NOT EXISTS captures (
  host TEXT NOT NULL, job_id BIGINT NOT NULL, n INTEGER NOT NULL,
  capture_id TEXT NOT NULL, pose JSONB NOT NULL, cloud_path TEXT NOT NULL,
  cloud_sha256 TEXT NOT NULL, points BIGINT NOT NULL,
  PRIMARY KEY (host, job_id, n), FOREIGN KEY (host, job_id) REFERENCES jobs ON DELETE CASCADE);
CREATE TABLE IF NOT EXISTS results (
  host TEXT NOT NULL, job_id BIGINT NOT NULL, n INTEGER NOT NULL,
  feature TEXT NOT NULL, fit JSONB NOT NULL, decision JSONB NOT NULL,
  PRIMARY KEY (host, job_id, n), FOREIGN KEY (host, job_id) REFERENCES jobs ON DELETE CASCADE);
CREATE INDEX IF NOT EXISTS results_feature ON results (feature);
CREATE TABLE IF NOT EXISTS offset_writes (
  host TEXT NOT NULL, job_id BIGINT NOT NULL, n INTEGER NOT NULL,
  adapter TEXT NOT NULL, target TEXT NOT NULL, before JSONB NOT NULL, after JSONB NOT NULL,
  written_utc TEXT NOT NULL, state TEXT NOT NULL,
  PRIMARY KEY (host, job_id, n), FOREIGN KEY (host, job_id) REFERENCES jobs ON DELETE CASCADE);
)sql";

constexpr int kSchemaVersion = 1;

std::string Text(const json& j, const char* key) {
  return j.contains(key) && j.at(key).is_string() ? j.at(key).get<std::string>() : std::string();
}

std::optional<std::string> JsonOrNull(const json& j, const char* key) {
  if (!j.contains(key) || j.at(key).is_null()) return std::nullopt;
  return base::json_fields::DumpText(j.at(key));
}

// A connection the server has closed (stopped, restarted, a network that dropped it) has its
// goodbye or EOF waiting on the socket; an idle healthy one has nothing to read. Asked before
// each use, so that a dead connection is replaced rather than used: libpqxx 6.4 leaks the
// PGresult of a statement that fails on a broken connection (2264 bytes, found by
// LeakSanitizer in AServerAwayIsATypedErrorAndTheNextCallReconnects). A server that dies in the
// middle of a transaction still takes that path, once per outage.
bool Closed(const pqxx::connection& c) {
  const int fd = c.sock();
  if (fd < 0) return true;
  pollfd p{fd, POLLIN, 0};
  return poll(&p, 1, 0) != 0;  // readable, hung up or failed: replace it
}

json Stored(const pqxx::field& f) { return f.is_null() ? json() : json::parse(f.c_str()); }

std::string PercentDecoded(const std::string& text) {
  std::string out;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '%' && i + 2 < text.size() &&
        std::isxdigit(static_cast<unsigned char>(text[i + 1])) &&
        std::isxdigit(static_cast<unsigned char>(text[i + 2]))) {
      out += static_cast<char>(std::stoi(text.substr(i + 1, 2), nullptr, 16));
      i += 2;
    } else {
      out += text[i];
    }
  }
  return out;
}

// The secrets a connection string may hold: a URI's password (as written and decoded; libpq
// takes the user info up to the first '@' or '/') and every `password=` value, in a URI's query
// or a keyword string.
std::vector<std::string> Secrets(const std::string& connection) {
  std::vector<std::string> out;
  const std::size_t scheme = connection.find("://");
  if (scheme != std::string::npos) {
    const std::size_t start = scheme + 3;
    const std::size_t end = connection.find_first_of("@/", start);
    if (end != std::string::npos && connection[end] == '@') {
      const std::size_t colon = connection.find(':', start);
      if (colon != std::string::npos && colon < end)
        out.push_back(connection.substr(colon + 1, end - colon - 1));
    }
  }
  static const std::regex kPassword(R"(password\s*=\s*('(?:[^'\\]|\\.)*'|[^&\s]*))",
                                    std::regex::icase);
  for (std::sregex_iterator it(connection.begin(), connection.end(), kPassword), end; it != end;
       ++it) {
    std::string value = (*it)[1].str();
    if (value.size() >= 2 && value.front() == '\'') value = value.substr(1, value.size() - 2);
    out.push_back(value);
  }
  std::vector<std::string> all;
  for (const std::string& secret : out) {
    if (secret.empty()) continue;
    all.push_back(secret);
    all.push_back(PercentDecoded(secret));
  }
  // The longest first: a password that holds another is replaced whole.
  std::sort(all.begin(), all.end(),
            [](const std::string& a, const std::string& b) { return a.size() > b.size(); });
  return all;
}

// libpq quotes a malformed connection string whole in its errors (unexpected character, bad
// percent-encoding, an IPv6 bracket left open): every secret is replaced before a message
// leaves this file.
std::string Redacted(std::string message, const std::vector<std::string>& secrets) {
  for (const std::string& secret : secrets) {
    for (std::size_t at = message.find(secret); at != std::string::npos;
         at = message.find(secret, at + 3))
      message.replace(at, secret.size(), "***");
  }
  return message;
}

// libpq waits for ever on a server that accepts and never answers (`mlp history --db` hung),
// and a statement on a locked table as long as the lock: a bound on both, unless the
// connection sets its own. connect_timeout counts the whole start-up, authentication included.
constexpr int kConnectTimeoutS = 5;
constexpr const char* kStatementLimits = "-c statement_timeout=30000 -c lock_timeout=10000";

std::string WithLimits(const std::string& connection) {
  std::string out = connection;
  const bool uri = IsDatabaseUri(connection);
  const auto add = [&](const std::string& key, const std::string& value) {
    if (connection.find(key + "=") != std::string::npos) return;
    if (uri) {
      out += (out.find('?') == std::string::npos ? "?" : "&") + key + "=";
      for (char c : value) out += c == ' ' ? "%20" : c == '=' ? "%3D" : std::string(1, c);
    } else {
      out += " " + key + "='" + value + "'";
    }
  };
  add("connect_timeout", std::to_string(kConnectTimeoutS));
  add("options", kStatementLimits);
  return out;
}

}  // namespace

bool IsDatabaseUri(const std::string& text) {
  return text.rfind("postgresql://", 0) == 0 || text.rfind("postgres://", 0) == 0;
}

struct PlantDatabase::Impl {
  std::string connection;
  std::vector<std::string> secrets;
  mutable std::mutex m;
  mutable std::unique_ptr<pqxx::connection> db;
  bool prepared = false;
  // The socket of the statement running now (-1: none), for Interrupt; fd_m keeps it from being
  // shut down after the connection that owned it is gone.
  mutable std::mutex fd_m;
  mutable int busy_fd = -1;

  [[noreturn]] void Fail(const std::string& message) const {
    throw PlantDatabaseError(Redacted(message, secrets));
  }

  void SetBusy(int fd) const {
    std::lock_guard lock(fd_m);
    busy_fd = fd;
  }

  // The connection string may hold a password: errors name the database by host and name.
  std::string Where() const {
    if (!db) return "the plant database";
    return std::string("the plant database ") + db->dbname() + " on " +
           (db->hostname() ? db->hostname() : "the local socket");
  }

  pqxx::connection& Db() const {
    if (db && db->is_open() && !Closed(*db)) return *db;
    db.reset();
    try {
      db = std::make_unique<pqxx::connection>(connection);
    } catch (const std::exception& e) {  // pqxx::failure, or argument_error for a bad string
      Fail(std::string("the plant database cannot be reached: ") + e.what());
    }
    return *db;
  }

  // Runs `body` in a transaction; a failure drops the connection (made again next time).
  template <typename Body>
  auto InTransaction(const std::string& what, Body body) const {
    std::lock_guard lock(m);
    // Cleared before the connection can go (a catch below may drop it).
    struct Idle {
      const Impl& d;
      ~Idle() { d.SetBusy(-1); }
    } idle{*this};
    try {
      pqxx::connection& c = Db();
      SetBusy(c.sock());
      pqxx::work tx(c);
      if constexpr (std::is_void_v<decltype(body(tx))>) {
        body(tx);
        tx.commit();
      } else {
        auto out = body(tx);
        tx.commit();
        return out;
      }
    } catch (const pqxx::sql_error& e) {
      Fail(Where() + ": " + what + ": " + e.what());
    } catch (const pqxx::failure& e) {
      const std::string where = Where();
      SetBusy(-1);
      db.reset();
      Fail(where + ": " + what + ": " + e.what());
    } catch (const json::exception& e) {
      Fail(Where() + ": " + what + ": a stored value that is not JSON: " + e.what());
    }
  }
};

PlantDatabase::PlantDatabase(const std::string& connection) : impl_(std::make_unique<Impl>()) {
  impl_->secrets = Secrets(connection);
  impl_->connection = WithLimits(connection);  // the limits add no secret
}

void PlantDatabase::Interrupt() {
  std::lock_guard lock(impl_->fd_m);
  // shutdown, not close: the descriptor stays libpq's; its blocked read returns at once.
  if (impl_->busy_fd >= 0) ::shutdown(impl_->busy_fd, SHUT_RDWR);
}

PlantDatabase::~PlantDatabase() = default;

void PlantDatabase::Prepare() {
  impl_->InTransaction("creating the tables", [](pqxx::work& tx) {
    // Two hosts starting at once must not both create: one waits for the other.
    tx.exec("SELECT pg_advisory_xact_lock(7420)");
    tx.exec(kSchema);
    const int version =
        tx.exec1("SELECT value FROM mlp_meta WHERE key = 'schema_version'")[0].as<int>();
    if (version > kSchemaVersion)
      throw pqxx::sql_error("schema version " + std::to_string(version) +
                            " is newer than this program's " + std::to_string(kSchemaVersion));
  });
  impl_->prepared = true;
}

void PlantDatabase::Send(const std::string& host, const json& job) {
  if (!impl_->prepared) Prepare();
  const std::int64_t id = job.at("id").get<std::int64_t>();
  impl_->InTransaction("sending job " + std::to_string(id), [&](pqxx::work& tx) {
    tx.exec_params("DELETE FROM jobs WHERE host = $1 AND id = $2", host, id);
    const std::optional<std::string> finished =
        Text(job, "finished_utc").empty() ? std::nullopt
                                          : std::optional<std::string>(Text(job, "finished_utc"));
    tx.exec_params(
        "INSERT INTO jobs (host, id, machine, kind, probe_serial, calibration_id, request, "
        "status, reply, timings_ms, started_utc, finished_utc) VALUES ($1, $2, $3, $4, $5, $6, "
        "$7::jsonb, $8, $9::jsonb, $10::jsonb, $11, $12)",
        host, id, Text(job, "machine"), Text(job, "kind"), Text(job, "probe_serial"),
        Text(job, "calibration_id"), base::json_fields::DumpText(job.at("request")),
        Text(job, "status"), JsonOrNull(job, "reply"), JsonOrNull(job, "timings_ms"),
        Text(job, "started_utc"), finished);
    int n = 0;
    for (const json& c : job.value("captures", json::array()))
      tx.exec_params("INSERT INTO captures VALUES ($1, $2, $3, $4, $5::jsonb, $6, $7, $8)", host,
                     id, n++, Text(c, "capture_id"), base::json_fields::DumpText(c.at("pose")),
                     Text(c, "cloud_path"), Text(c, "cloud_sha256"),
                     c.value("points", std::int64_t{0}));
    n = 0;
    for (const json& r : job.value("results", json::array()))
      tx.exec_params("INSERT INTO results VALUES ($1, $2, $3, $4, $5::jsonb, $6::jsonb)", host, id,
                     n++, Text(r, "feature"), base::json_fields::DumpText(r.at("fit")),
                     base::json_fields::DumpText(r.at("decision")));
    n = 0;
    for (const json& w : job.value("offset_writes", json::array()))
      tx.exec_params(
          "INSERT INTO offset_writes VALUES ($1, $2, $3, $4, $5, $6::jsonb, $7::jsonb, $8, $9)",
          host, id, n++, Text(w, "adapter"), Text(w, "target"),
          base::json_fields::DumpText(w.at("before")), base::json_fields::DumpText(w.at("after")),
          Text(w, "written_utc"), Text(w, "state"));
  });
}

std::vector<history::JobSummary> PlantDatabase::ListJobs(const history::JobFilter& f) const {
  return impl_->InTransaction("listing jobs", [&](pqxx::work& tx) {
    const pqxx::result r = tx.exec_params(
        "SELECT host, id, machine, kind, probe_serial, calibration_id, status, started_utc, "
        "COALESCE(finished_utc, '') FROM jobs WHERE ($1::text IS NULL OR machine = $1) AND "
        "($2::text IS NULL OR kind = $2) AND ($3::text IS NULL OR started_utc >= $3) AND "
        "($4::text IS NULL OR host = $4) ORDER BY started_utc, host, id LIMIT $5",
        f.machine, f.kind, f.since_utc, f.host, f.limit);
    std::vector<history::JobSummary> out;
    for (const auto& row : r) {
      history::JobSummary s;
      s.host = row[0].as<std::string>();
      s.id = row[1].as<std::int64_t>();
      s.machine = row[2].as<std::string>();
      s.kind = row[3].as<std::string>();
      s.probe_serial = row[4].as<std::string>();
      s.calibration_id = row[5].as<std::string>();
      s.status = history::JobStatusFrom(row[6].as<std::string>());
      s.started_utc = row[7].as<std::string>();
      s.finished_utc = row[8].as<std::string>();
      out.push_back(std::move(s));
    }
    return out;
  });
}

std::vector<history::FeatureResult> PlantDatabase::FeatureResults(
    const history::FeatureQuery& f) const {
  auto out = impl_->InTransaction("reading results", [&](pqxx::work& tx) {
    const pqxx::result r = tx.exec_params(
        "SELECT j.host, j.id, j.machine, j.started_utc, j.status, r.fit, j.request FROM "
        "results r JOIN jobs j ON j.host = r.host AND j.id = r.job_id WHERE r.feature = $1 AND "
        "($2::text IS NULL OR j.machine = $2) AND j.kind = 'measure' AND j.status IN "
        "('in_tolerance', 'out_of_tolerance') ORDER BY j.started_utc DESC, j.host DESC, j.id "
        "DESC LIMIT $3",
        f.feature, f.machine, f.last);
    std::vector<history::FeatureResult> results;
    for (const auto& row : r) {
      history::FeatureResult x;
      x.host = row[0].as<std::string>();
      x.job = row[1].as<std::int64_t>();
      x.machine = row[2].as<std::string>();
      x.started_utc = row[3].as<std::string>();
      x.status = history::JobStatusFrom(row[4].as<std::string>());
      x.fit = Stored(row[5]);
      x.request = Stored(row[6]);
      results.push_back(std::move(x));
    }
    return results;
  });
  std::reverse(out.begin(), out.end());
  return out;
}

json PlantDatabase::ExportJob(std::int64_t job, const std::string& host) const {
  return impl_->InTransaction("exporting job " + std::to_string(job), [&](pqxx::work& tx) {
    const std::optional<std::string> only =
        host.empty() ? std::nullopt : std::optional<std::string>(host);
    const pqxx::result r = tx.exec_params(
        "SELECT host, machine, kind, probe_serial, calibration_id, request, status, reply, "
        "timings_ms, started_utc, COALESCE(finished_utc, '') FROM jobs WHERE id = $1 AND "
        "($2::text IS NULL OR host = $2) ORDER BY host",
        job, only);
    if (r.empty()) throw pqxx::sql_error("no job " + std::to_string(job));
    if (r.size() > 1) {
      std::string hosts;
      for (const auto& row : r) hosts += (hosts.empty() ? "" : ", ") + row[0].as<std::string>();
      throw pqxx::sql_error("job " + std::to_string(job) + " exists on hosts " + hosts +
                            ": name one (--host)");
    }
    const auto& row = r[0];
    const std::string h = row[0].as<std::string>();
    json j = {{"host", h},
              {"id", job},
              {"machine", row[1].as<std::string>()},
              {"kind", row[2].as<std::string>()},
              {"probe_serial", row[3].as<std::string>()},
              {"calibration_id", row[4].as<std::string>()},
              {"request", Stored(row[5])},
              {"status", row[6].as<std::string>()},
              {"reply", Stored(row[7])},
              {"timings_ms", Stored(row[8])},
              {"started_utc", row[9].as<std::string>()},
              {"finished_utc", row[10].as<std::string>()}};
    j["captures"] = json::array();
    for (const auto& c : tx.exec_params("SELECT capture_id, pose, cloud_path, cloud_sha256, "
                                        "points FROM captures WHERE host = $1 AND job_id = $2 "
                                        "ORDER BY n",
                                        h, job))
      j["captures"].push_back({{"capture_id", c[0].as<std::string>()},
                               {"pose", Stored(c[1])},
                               {"cloud_path", c[2].as<std::string>()},
                               {"cloud_sha256", c[3].as<std::string>()},
                               {"points", c[4].as<std::int64_t>()}});
    j["results"] = json::array();
    for (const auto& x : tx.exec_params("SELECT feature, fit, decision FROM results WHERE host = "
                                        "$1 AND job_id = $2 ORDER BY n",
                                        h, job))
      j["results"].push_back(
          {{"feature", x[0].as<std::string>()}, {"fit", Stored(x[1])}, {"decision", Stored(x[2])}});
    j["offset_writes"] = json::array();
    for (const auto& w : tx.exec_params("SELECT adapter, target, before, after, written_utc, "
                                        "state FROM offset_writes WHERE host = $1 AND job_id = "
                                        "$2 ORDER BY n",
                                        h, job))
      j["offset_writes"].push_back({{"adapter", w[0].as<std::string>()},
                                    {"target", w[1].as<std::string>()},
                                    {"before", Stored(w[2])},
                                    {"after", Stored(w[3])},
                                    {"written_utc", w[4].as<std::string>()},
                                    {"state", w[5].as<std::string>()}});
    return j;
  });
}

}  // namespace mlp::plant
