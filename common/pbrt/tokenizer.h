// The pbrt-v4 scene format's tokens: quoted strings, '[' and ']', and runs of other characters
// (directive names, numbers, bare true/false), with '#' comments to the end of a line. Each token
// knows where it was written, so every message can name the file, line and column.
#pragma once

#include <memory>
#include <string>
#include <string_view>

namespace alphorn::pbrt {

// Where a token was written. `file` names the file as messages show it.
struct Location {
    std::shared_ptr<const std::string> file;
    int line = 0;
    int column = 0;
    std::string toString() const;
};

struct Token {
    std::string_view text;  // as written: a string token keeps its quotes
    Location location;
    bool isString() const { return text.size() >= 2 && text.front() == '"'; }
    // A string token's value, escapes resolved; the caller checks isString() first.
    std::string stringValue() const;
};

// Splits one file's text into tokens. The text must outlive the tokenizer and its tokens.
class Tokenizer {
  public:
    Tokenizer(std::string_view text, std::shared_ptr<const std::string> fileName);

    // The next token, or false at the end of the text. Throws Error("file:line:col: problem")
    // for a string that is not closed on its line or a NUL byte.
    bool next(Token& token);

  private:
    char peek() const { return m_pos < m_text.size() ? m_text[m_pos] : '\0'; }
    void advance();

    std::string_view m_text;
    std::shared_ptr<const std::string> m_file;
    size_t m_pos = 0;
    int m_line = 1;
    int m_column = 1;
};

}  // namespace alphorn::pbrt
