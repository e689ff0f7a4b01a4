#include "quadtune/engine/store/row_codec.hpp"

#include <bit>
#include <cstring>

namespace quadtune::engine {
namespace {

// Header: tag byte, 8-byte sequence, 4-byte row count.
constexpr std::size_t kHeader = 1 + 8 + 4;

void PutU64(std::string& out, std::uint64_t v) {
  char b[8];
  for (int i = 0; i < 8; ++i) b[i] = static_cast<char>((v >> (8 * i)) & 0xffU);
  out.append(b, 8);
}
void PutU32(std::string& out, std::uint32_t v) {
  char b[4];
  for (int i = 0; i < 4; ++i) b[i] = static_cast<char>((v >> (8 * i)) & 0xffU);
  out.append(b, 4);
}
void PutString(std::string& out, const std::string& s) {
  if (s.size() > 0xffffffffULL) throw CodecError("row codec: string longer than 4 GiB");
  PutU32(out, static_cast<std::uint32_t>(s.size()));
  out.append(s);
}

/// Reads fields from the front of a byte range; throws CodecError when it runs out.
class Reader {
 public:
  explicit Reader(std::string_view bytes) : rest_(bytes) {}
  std::uint64_t U64() { return Little(8); }
  std::uint32_t U32() { return static_cast<std::uint32_t>(Little(4)); }
  std::int64_t I64() { return static_cast<std::int64_t>(U64()); }
  double F64() { return std::bit_cast<double>(U64()); }
  std::string String() {
    const std::uint32_t n = U32();
    Need(n);
    std::string s(rest_.substr(0, n));
    rest_.remove_prefix(n);
    return s;
  }
  char Byte() {
    Need(1);
    const char c = rest_.front();
    rest_.remove_prefix(1);
    return c;
  }
  [[nodiscard]] bool Done() const { return rest_.empty(); }

 private:
  void Need(std::size_t n) const {
    if (rest_.size() < n) throw CodecError("row codec: truncated batch");
  }
  std::uint64_t Little(int n) {
    Need(static_cast<std::size_t>(n));
    std::uint64_t v = 0;
    for (int i = 0; i < n; ++i) {
      v |=
          static_cast<std::uint64_t>(static_cast<unsigned char>(rest_[static_cast<std::size_t>(i)]))
          << (8 * i);
    }
    rest_.remove_prefix(static_cast<std::size_t>(n));
    return v;
  }
  std::string_view rest_;
};

}  // namespace

RowBatch::RowBatch(std::uint64_t sequence) : sequence_(sequence) {
  bytes_.push_back(kBatchTag);
  PutU64(bytes_, sequence_);
  PutU32(bytes_, 0);  // the row count, filled in by Bytes()
}

void RowBatch::Add(const EvaluationRow& r) {
  for (const auto& c : EvaluationColumns().List()) {
    const ColumnValue v = c.get(r);
    switch (c.type) {
      case ColumnType::kInteger:
        PutU64(bytes_, static_cast<std::uint64_t>(std::get<std::int64_t>(v)));
        break;
      case ColumnType::kReal:
        PutU64(bytes_, std::bit_cast<std::uint64_t>(std::get<double>(v)));
        break;
      case ColumnType::kSeed: PutU64(bytes_, std::get<std::uint64_t>(v)); break;
      case ColumnType::kValues: throw CodecError("row codec: a stored column holds no map");
      default: PutString(bytes_, std::get<std::string>(v)); break;
    }
  }
  ++rows_;
}

const std::string& RowBatch::Bytes() {
  for (int i = 0; i < 4; ++i) {
    bytes_[static_cast<std::size_t>(1 + 8 + i)] = static_cast<char>((rows_ >> (8 * i)) & 0xffU);
  }
  return bytes_;
}

std::uint64_t DecodeBatch(std::string_view bytes, std::vector<EvaluationRow>& rows) {
  if (bytes.size() < kHeader) throw CodecError("row codec: truncated batch");
  Reader in(bytes);
  if (in.Byte() != kBatchTag) throw CodecError("row codec: not a batch of rows");
  const std::uint64_t sequence = in.U64();
  const std::uint32_t count = in.U32();
  rows.reserve(rows.size() + count);
  for (std::uint32_t i = 0; i < count; ++i) {
    EvaluationRow& r = rows.emplace_back();
    for (const auto& c : EvaluationColumns().List()) {
      try {
        switch (c.type) {
          case ColumnType::kInteger: c.set(r, ColumnValue(in.I64())); break;
          case ColumnType::kReal: c.set(r, ColumnValue(in.F64())); break;
          case ColumnType::kSeed: c.set(r, ColumnValue(in.U64())); break;
          case ColumnType::kValues: throw CodecError("row codec: a stored column holds no map");
          default: c.set(r, ColumnValue(in.String())); break;
        }
      } catch (const ColumnError& e) {
        throw CodecError(std::string("row codec: ") + e.what());
      }
    }
  }
  if (!in.Done()) throw CodecError("row codec: bytes after the last row");
  return sequence;
}

}  // namespace quadtune::engine
