#include "common/pbrt/tokenizer.h"

#include "common/core/error.h"

#include <absl/strings/str_format.h>

namespace alphorn::pbrt {

std::string Location::toString() const {
    return absl::StrFormat("%s:%d:%d", file ? *file : std::string("<unknown>"), line, column);
}

std::string Token::stringValue() const {
    std::string out;
    out.reserve(text.size() - 2);
    for (size_t i = 1; i + 1 < text.size(); ++i) {
        char c = text[i];
        if (c == '\\' && i + 2 < text.size()) {
            switch (text[++i]) {
                case 'b':
                    c = '\b';
                    break;
                case 'f':
                    c = '\f';
                    break;
                case 'n':
                    c = '\n';
                    break;
                case 'r':
                    c = '\r';
                    break;
                case 't':
                    c = '\t';
                    break;
                default:
                    c = text[i];
                    break;  // \\, \", \' and any other character as itself
            }
        }
        out += c;
    }
    return out;
}

Tokenizer::Tokenizer(std::string_view text, std::shared_ptr<const std::string> fileName)
    : m_text(text), m_file(std::move(fileName)) {}

void Tokenizer::advance() {
    if (m_text[m_pos] == '\n') {
        ++m_line;
        m_column = 1;
    } else {
        ++m_column;
    }
    ++m_pos;
}

bool Tokenizer::next(Token& token) {
    for (;;) {
        const char c = peek();
        if (m_pos >= m_text.size()) return false;
        if (c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\f' || c == '\v') {
            advance();
        } else if (c == '#') {
            while (m_pos < m_text.size() && m_text[m_pos] != '\n') advance();
        } else {
            break;
        }
    }
    const size_t start = m_pos;
    token.location = Location{m_file, m_line, m_column};
    const char c = peek();
    if (c == '\0')
        throw Error(token.location.toString() + ": a NUL byte; a pbrt scene file is text");
    if (c == '[' || c == ']') {
        advance();
    } else if (c == '"') {
        advance();
        for (;;) {
            if (m_pos >= m_text.size() || m_text[m_pos] == '\n')
                throw Error(token.location.toString() +
                            ": a string that is not closed on its line (a '\"' is missing)");
            if (m_text[m_pos] == '\0')
                throw Error(token.location.toString() + ": a NUL byte inside a string");
            if (m_text[m_pos] == '\\' && m_pos + 1 < m_text.size() && m_text[m_pos + 1] != '\n') {
                advance();
                advance();
                continue;
            }
            const bool closing = m_text[m_pos] == '"';
            advance();
            if (closing) break;
        }
    } else {
        while (m_pos < m_text.size()) {
            const char d = m_text[m_pos];
            if (d == ' ' || d == '\t' || d == '\n' || d == '\r' || d == '\f' || d == '\v' ||
                d == '"' || d == '[' || d == ']' || d == '#' || d == '\0')
                break;
            advance();
        }
    }
    token.text = m_text.substr(start, m_pos - start);
    return true;
}

}  // namespace alphorn::pbrt
