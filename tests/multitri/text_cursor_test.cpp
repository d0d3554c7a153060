#include "multitri/detail/text_cursor.hpp"

#include <cstddef>
#include <random>
#include <string>
#include <string_view>
#include <vector>

#include <gtest/gtest.h>

namespace varmesh::detail {
namespace {

constexpr std::size_t kNpos = std::string_view::npos;

// The slow reference: the first CR that is the last byte or is followed by something other than LF.
std::size_t oracle_lone_cr(std::string_view text) {
  for (std::size_t i = 0; i < text.size(); ++i)
    if (text[i] == '\r' && (i + 1 == text.size() || text[i + 1] != '\n')) return i;
  return kNpos;
}

// The slow reference conversion: each lone CR becomes LF, everything else stays.
std::string oracle_to_lf(std::string_view text) {
  std::string out(text);
  for (std::size_t i = 0; i < text.size(); ++i)
    if (text[i] == '\r' && (i + 1 == text.size() || text[i + 1] != '\n')) out[i] = '\n';
  return out;
}

// Checks both functions on `text` against the references. find_lone_cr's blocks start at the first CR,
// so callers vary where that CR sits as well as where the lone one does.
void check(std::string_view text) {
  const std::size_t expected = oracle_lone_cr(text);
  ASSERT_EQ(find_lone_cr(text), expected) << "size " << text.size();
  std::string storage;
  const std::string_view converted = lone_cr_to_lf(text, storage);
  // The documented contract: the input itself when there is nothing to change, else a copy in storage.
  if (expected == kNpos)
    ASSERT_EQ(converted.data(), text.data()) << "size " << text.size();
  else
    ASSERT_EQ(converted.data(), storage.data()) << "size " << text.size();
  ASSERT_EQ(converted, oracle_to_lf(text)) << "size " << text.size();
  ASSERT_EQ(oracle_lone_cr(converted), kNpos) << "size " << text.size();
  ASSERT_EQ(find_lone_cr(converted), kNpos) << "size " << text.size();
}

// Offsets around the 256-byte blocks, near the start and near the end of a text of `size` bytes.
std::vector<std::size_t> offsets_near_blocks(std::size_t size) {
  std::vector<std::size_t> out;
  const std::size_t candidates[] = {0, 1, 2, 254, 255, 256, 257, 258, 510, 511, 512, 513, 514};
  for (std::size_t c : candidates)
    if (c < size) out.push_back(c);
  for (std::size_t back = 1; back <= 3 && back <= size; ++back) out.push_back(size - back);
  return out;
}

const std::size_t kSizes[] = {1, 2, 3, 255, 256, 257, 258, 511, 512, 513, 514, 515, 767, 768, 769, 1000};

TEST(TextCursorLoneCr, EmptyAndCrFreeTexts) {
  check("");
  check("a");
  check("\n");
  check(std::string(255, 'a'));
  check(std::string(256, 'a'));
  check(std::string(257, 'a'));
  check(std::string(1000, '\n'));
}

// One CR in a text of 'a's, at every offset near a block edge and near the end: always lone.
TEST(TextCursorLoneCr, SingleCrAtBlockEdges) {
  for (std::size_t size : kSizes)
    for (std::size_t at : offsets_near_blocks(size)) {
      SCOPED_TRACE(testing::Message() << "size " << size << " cr at " << at);
      std::string text(size, 'a');
      text[at] = '\r';
      ASSERT_EQ(find_lone_cr(text), at);
      check(text);
    }
}

// One CRLF at every such offset: nothing is lone. Then a lone CR added at every such offset after it.
TEST(TextCursorLoneCr, CrlfAtBlockEdgesThenLoneCr) {
  for (std::size_t size : kSizes)
    for (std::size_t at : offsets_near_blocks(size)) {
      if (at + 1 >= size) continue;
      SCOPED_TRACE(testing::Message() << "size " << size << " crlf at " << at);
      std::string text(size, 'a');
      text[at] = '\r';
      text[at + 1] = '\n';
      ASSERT_EQ(find_lone_cr(text), kNpos);
      check(text);
      for (std::size_t lone : offsets_near_blocks(size)) {
        if (lone <= at + 1) continue;
        SCOPED_TRACE(testing::Message() << "lone cr at " << lone);
        std::string with_lone = text;
        with_lone[lone] = '\r';
        ASSERT_EQ(find_lone_cr(with_lone), lone);
        check(with_lone);
      }
    }
}

// The blocks are counted from the first CR. A CRLF at `first` starts them; a lone CR then sits at every
// offset from there to past the second block, so each block's first and last byte and each boundary are
// hit wherever the blocks start.
TEST(TextCursorLoneCr, EveryOffsetFromTheFirstCr) {
  const std::size_t firsts[] = {0, 1, 2, 7, 254, 255, 256, 257};
  for (std::size_t first : firsts) {
    const std::size_t size = first + 2 * 256 + 8;
    const std::string base = std::string(first, 'a') + "\r\n" + std::string(size - first - 2, 'a');
    for (std::size_t lone = first + 2; lone < size; ++lone) {
      SCOPED_TRACE(testing::Message() << "first cr " << first << " lone cr " << lone);
      std::string text = base;
      text[lone] = '\r';
      ASSERT_EQ(find_lone_cr(text), lone);
      check(text);
      // The same CR followed by LF is not lone, so the text has none.
      if (lone + 1 < size) {
        text[lone + 1] = '\n';
        ASSERT_EQ(find_lone_cr(text), kNpos);
        check(text);
      }
    }
  }
}

// A CRLF split across a block boundary: the CR is the last byte that a block tests and the LF is the first
// byte of the next block. Both with the first CR at offset 0 and further in.
TEST(TextCursorLoneCr, CrlfSplitAcrossABlockBoundary) {
  const std::size_t firsts[] = {0, 3, 300};
  for (std::size_t first : firsts)
    for (std::size_t block = 1; block <= 3; ++block) {
      SCOPED_TRACE(testing::Message() << "first cr " << first << " block " << block);
      const std::size_t cr = first + block * 256 - 1;
      std::string text(cr + 40, 'a');
      text[first] = '\r';
      text[first + 1] = '\n';
      text[cr] = '\r';
      text[cr + 1] = '\n';
      ASSERT_EQ(find_lone_cr(text), kNpos);
      check(text);
      // A lone CR just after the split pair is still found, in the next block.
      text[cr + 2] = '\r';
      ASSERT_EQ(find_lone_cr(text), cr + 2);
      check(text);
      // A CR at the block's last byte with no LF after it is lone.
      text[cr + 1] = 'a';
      ASSERT_EQ(find_lone_cr(text), cr);
      check(text);
    }
}

// A CR as the very last byte has no byte after it, so it is lone, whatever precedes it and also when the
// memory after the view holds an LF (a view into a longer buffer must not look past its end).
TEST(TextCursorLoneCr, CrAsTheLastByte) {
  for (std::size_t size : kSizes) {
    SCOPED_TRACE(testing::Message() << "size " << size);
    std::string buffer(size + 1, 'a');
    buffer[size - 1] = '\r';
    buffer[size] = '\n';
    const std::string_view text(buffer.data(), size);
    ASSERT_EQ(find_lone_cr(text), size - 1);
    check(text);
    // Preceded by CRLFs that start the blocks early, and by a CR (CR CR at the end: the first is lone).
    std::string crlfs = buffer;
    for (std::size_t i = 0; i + 2 < size; i += 2) {
      crlfs[i] = '\r';
      crlfs[i + 1] = '\n';
    }
    ASSERT_EQ(find_lone_cr(std::string_view(crlfs.data(), size)), size - 1);
    check(std::string_view(crlfs.data(), size));
    if (size >= 2) {
      buffer[size - 2] = '\r';
      ASSERT_EQ(find_lone_cr(text), size - 2);
      check(text);
    }
  }
}

// Random texts of many lengths. Over {'a', CR, LF} a lone CR comes early, so texts built from "a", LF and
// CRLF with a rarer lone CR put it at every depth, and some texts have none.
TEST(TextCursorLoneCr, RandomTextsMatchTheOracle) {
  std::mt19937 rng(20240611u);
  const char alphabet[] = {'a', '\r', '\n'};
  std::uniform_int_distribution<int> pick(0, 2);
  for (std::size_t size = 0; size <= 1100; ++size)
    for (int rep = 0; rep < 3; ++rep) {
      std::string text(size, 'a');
      for (char& c : text) c = alphabet[pick(rng)];
      SCOPED_TRACE(testing::Message() << "uniform size " << size << " rep " << rep);
      check(text);
    }
  const double lone_rates[] = {0.0, 0.0005, 0.003, 0.02};
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (double rate : lone_rates)
    for (std::size_t target = 0; target <= 1100; target += 3) {
      std::string text;
      while (text.size() < target) {
        const double u = unit(rng);
        if (u < rate) text += '\r';
        else if (u < 0.3) text += "\r\n";
        else if (u < 0.4) text += '\n';
        else text += 'a';
      }
      SCOPED_TRACE(testing::Message() << "rate " << rate << " size " << text.size());
      check(text);
    }
}


// The tokens of each statement and the line of each token, read the way the OBJ reader reads them.
struct Read {
  std::vector<std::vector<std::string>> statements;
  std::vector<std::size_t> token_lines;
  std::vector<std::size_t> statement_lines;
};

Read read_statements(std::string_view text, bool continuations) {
  const std::string file = "t";
  TextCursor cur(text, file, '#', continuations);
  Read out;
  while (cur.skip_empty_lines()) {
    cur.begin_statement();
    out.statement_lines.push_back(cur.statement_line());
    out.statements.emplace_back();
    for (std::string_view tok = cur.token(); !tok.empty(); tok = cur.token()) {
      out.statements.back().emplace_back(tok);
      out.token_lines.push_back(cur.line());
    }
    cur.next_statement();
  }
  return out;
}

using Statements = std::vector<std::vector<std::string>>;

// A backslash with only blanks after it on its line is a blank that joins the next line, glued to a token
// or not, at the end of the text too; a comment is not continued; a backslash elsewhere is an ordinary
// character. Lines stay physical lines.
TEST(TextCursorContinuations, JoinLinesAndCountThem) {
  const std::string text = "a b \\\nc\\ \t\r\nd\n# x \\\ne \\ f \\\\\n\n\\\ng \\\n# y\nh \\";
  const Read r = read_statements(text, true);
  EXPECT_EQ(r.statements, (Statements{{"a", "b", "c", "d"}, {"e", "\\", "f", "\\"}, {"g"}, {"h"}}));
  EXPECT_EQ(r.statement_lines, (std::vector<std::size_t>{1, 5, 8, 10}));
  EXPECT_EQ(r.token_lines, (std::vector<std::size_t>{1, 1, 2, 3, 5, 5, 5, 5, 8, 10}));
  // Without continuations (OFF, PLY), a backslash is an ordinary character everywhere.
  const Read plain = read_statements(text, false);
  EXPECT_EQ(plain.statements.front(), (std::vector<std::string>{"a", "b", "\\"}));
  EXPECT_EQ(plain.statements.size(), 7u);
}

// next_statement() skips a statement that was not read, with the lines it continues onto, and stops at a
// comment before a backslash.
TEST(TextCursorContinuations, NextStatementSkipsContinuedLines) {
  const std::string file = "t";
  const std::string text = "g a \\\n  b \\\nc\nd # e \\\nf\n";
  TextCursor cur(text, file, '#', true);
  ASSERT_TRUE(cur.skip_empty_lines());
  EXPECT_EQ(cur.token(), "g");
  cur.next_statement();
  EXPECT_EQ(cur.line(), 4u);
  EXPECT_EQ(cur.token(), "d");
  cur.next_statement();
  EXPECT_EQ(cur.line(), 5u);
  EXPECT_EQ(cur.token(), "f");
}

}  // namespace
}  // namespace varmesh::detail
