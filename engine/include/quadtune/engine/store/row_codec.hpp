#pragma once
/// \file
/// The compact binary form in which a distributed run ships evaluation rows to rank 0: every
/// column of EvaluationColumns(), in list order: integers, seeds and the bit patterns of the
/// doubles as 8 bytes in little-endian byte order (so a decoded row equals the encoded one bit
/// for bit on any host), text, enum names and JSON objects as a 32-bit length and their bytes.
/// A batch is a sequence number, a row count and the rows back to back.
///
/// Thread safety: plain functions on caller-owned data; RowBatch is a value (one thread at a
/// time).

#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "quadtune/engine/store/result_store.hpp"

namespace quadtune::engine {

/// Thrown when bytes are not a well-formed batch.
class CodecError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Rows being collected for one message: Add() encodes, Bytes() is the message.
class RowBatch {
 public:
  /// Starts an empty batch with sequence number `sequence`.
  explicit RowBatch(std::uint64_t sequence = 0);
  /// Appends `row`'s encoding.
  void Add(const EvaluationRow& row);
  [[nodiscard]] std::uint32_t Rows() const { return rows_; }
  [[nodiscard]] std::uint64_t Sequence() const { return sequence_; }
  /// The encoded batch (header with the row count, then the rows).
  [[nodiscard]] const std::string& Bytes();

 private:
  std::uint64_t sequence_;
  std::uint32_t rows_ = 0;
  std::string bytes_;
};

/// Decodes what RowBatch::Bytes() gave, appending the rows to `rows` (so that several batches
/// can share one vector); returns the sequence number. Throws CodecError on malformed bytes
/// (wrong tag, truncated, trailing bytes).
std::uint64_t DecodeBatch(std::string_view bytes, std::vector<EvaluationRow>& rows);

/// The first byte of every encoded batch (a JSON control message starts with '{').
inline constexpr char kBatchTag = 'B';

}  // namespace quadtune::engine
