#pragma once
/// @file The plant's one database (PostgreSQL, through libpqxx): every host sends its finished
/// jobs here, with their captures, results and offset writes, in the tables of a host's own
/// history plus the host's name; `mlp history` reads it as it reads a host's history. Several
/// hosts write at once: each job is one transaction, keyed by (host, job).

#include "mlp/history/history.h"

#include <memory>
#include <mutex>
#include <string>

#include <nlohmann/json.hpp>

namespace mlp::plant {

/// The database cannot be reached or refused a statement; the message says which and why (never
/// the password: libpq quotes a malformed connection string whole, so every password it holds
/// is replaced by *** in every message).
class PlantDatabaseError : public history::HistoryError {
 public:
  using history::HistoryError::HistoryError;
};

class PlantDatabase : public history::JobRecords {
 public:
  /// `connection`: a libpq connection string or URI. Connects lazily (a database that is away
  /// is no error until used); creates the tables the first time. Thread-safe (one connection,
  /// one statement at a time).
  explicit PlantDatabase(const std::string& connection);
  ~PlantDatabase() override;

  /// Creates the tables if they are missing (schema version 1); throws PlantDatabaseError.
  void Prepare();
  /// From another thread: the statement running now fails at once with PlantDatabaseError (its
  /// transaction is not committed). What a host that is asked to stop does to a send that
  /// waits on a stalled server. Connecting is bounded by connect_timeout (5 s, added to the
  /// connection unless it sets its own, with statement_timeout 30 s and lock_timeout 10 s).
  void Interrupt();
  /// One job as History::ExportJob gives it, from `host`: inserted, or replacing the earlier
  /// state of the same (host, job) with its children, in one transaction. Throws
  /// PlantDatabaseError (the connection is made again at the next call).
  void Send(const std::string& host, const nlohmann::json& job);

  std::vector<history::JobSummary> ListJobs(const history::JobFilter& filter) const override;
  std::vector<history::FeatureResult> FeatureResults(
      const history::FeatureQuery& query) const override;
  nlohmann::json ExportJob(std::int64_t job, const std::string& host = "") const override;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// True when `text` names a PostgreSQL database (a postgresql:// or postgres:// URI) rather than
/// a history file.
bool IsDatabaseUri(const std::string& text);

}  // namespace mlp::plant
