#include "codec/ub_json.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "ub/ub_error.h"

/* One scanner serves both the checking pass (msg set) and iteration over an
 * already-checked document (msg NULL, errors impossible). */
typedef struct scanner {
    const char *text;
    size_t len;
    size_t pos;
    uint32_t line;
    char *msg;
    size_t msg_cap;
    uint32_t err_line;
} scanner_t;

static int fail(scanner_t *s, uint32_t line, const char *fmt, ...) {
    s->err_line = line;
    if (s->msg != NULL && s->msg_cap > 0) {
        va_list ap;
        va_start(ap, fmt);
        (void)vsnprintf(s->msg, s->msg_cap, fmt, ap);
        va_end(ap);
    }
    return UB_ERR_CONFIG;
}

/* Printable ASCII is quoted; anything else is shown as a byte so the message
 * stays ASCII and identical in the Python port. */
static void describe_found(const scanner_t *s, char *buf, size_t cap) {
    if (s->pos >= s->len) {
        (void)snprintf(buf, cap, "end of file");
        return;
    }
    unsigned char c = (unsigned char)s->text[s->pos];
    if (c >= 0x20 && c <= 0x7e)
        (void)snprintf(buf, cap, "'%c'", c);
    else
        (void)snprintf(buf, cap, "byte 0x%02x", c);
}

static int fail_found(scanner_t *s, const char *expected) {
    char found[16];
    describe_found(s, found, sizeof found);
    return fail(s, s->line, "invalid JSON: expected %s, found %s", expected, found);
}

static void skip_ws(scanner_t *s) {
    while (s->pos < s->len) {
        char c = s->text[s->pos];
        if (c == '\n')
            s->line++;
        else if (c != ' ' && c != '\t' && c != '\r')
            return;
        s->pos++;
    }
}

static int hex_value(char c) {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}

/* Reads the 4 hex digits after "\u" at text[at]; -1 if they are not there. */
static long read_u4(const char *text, size_t len, size_t at) {
    if (at + 4 > len) return -1;
    long v = 0;
    for (size_t i = 0; i < 4; i++) {
        int h = hex_value(text[at + i]);
        if (h < 0) return -1;
        v = v * 16 + h;
    }
    return v;
}

static int scan_string(scanner_t *s) {
    uint32_t start_line = s->line;
    s->pos++; /* opening quote */
    for (;;) {
        if (s->pos >= s->len)
            return fail(s, start_line, "invalid JSON: unterminated string (missing closing '\"')");
        unsigned char c = (unsigned char)s->text[s->pos];
        if (c == '"') {
            s->pos++;
            return UB_OK;
        }
        if (c < 0x20)
            return fail(s, s->line,
                        "invalid JSON: control character 0x%02x in string (write it as an escape such as \\n)", c);
        if (c != '\\') {
            s->pos++;
            continue;
        }
        if (s->pos + 1 >= s->len)
            return fail(s, start_line, "invalid JSON: unterminated string (missing closing '\"')");
        char e = s->text[s->pos + 1];
        if (strchr("\"\\/bfnrt", e) != NULL && e != '\0') {
            s->pos += 2;
            continue;
        }
        if (e != 'u')
            return fail(s, s->line,
                        "invalid JSON: invalid escape in string (valid: \\\" \\\\ \\/ \\b \\f \\n \\r \\t \\uXXXX)");
        long cp = read_u4(s->text, s->len, s->pos + 2);
        if (cp < 0) return fail(s, s->line, "invalid JSON: invalid \\u escape (it needs 4 hex digits)");
        s->pos += 6;
        if (cp >= 0xDC00 && cp <= 0xDFFF)
            return fail(s, s->line, "invalid JSON: unpaired surrogate in \\u escape");
        if (cp >= 0xD800 && cp <= 0xDBFF) {
            long low = -1;
            if (s->pos + 1 < s->len && s->text[s->pos] == '\\' && s->text[s->pos + 1] == 'u')
                low = read_u4(s->text, s->len, s->pos + 2);
            if (low < 0xDC00 || low > 0xDFFF)
                return fail(s, s->line, "invalid JSON: unpaired surrogate in \\u escape");
            s->pos += 6;
        }
    }
}

static bool at_digit(const scanner_t *s) {
    return s->pos < s->len && s->text[s->pos] >= '0' && s->text[s->pos] <= '9';
}

static int scan_number(scanner_t *s) {
    if (s->text[s->pos] == '-') s->pos++;
    if (!at_digit(s)) return fail(s, s->line, "invalid JSON: invalid number");
    if (s->text[s->pos] == '0')
        s->pos++;
    else
        while (at_digit(s)) s->pos++;
    if (s->pos < s->len && s->text[s->pos] == '.') {
        s->pos++;
        if (!at_digit(s)) return fail(s, s->line, "invalid JSON: invalid number");
        while (at_digit(s)) s->pos++;
    }
    if (s->pos < s->len && (s->text[s->pos] == 'e' || s->text[s->pos] == 'E')) {
        s->pos++;
        if (s->pos < s->len && (s->text[s->pos] == '+' || s->text[s->pos] == '-')) s->pos++;
        if (!at_digit(s)) return fail(s, s->line, "invalid JSON: invalid number");
        while (at_digit(s)) s->pos++;
    }
    return UB_OK;
}

static int scan_literal(scanner_t *s, const char *word) {
    size_t n = strlen(word);
    if (s->len - s->pos < n || memcmp(s->text + s->pos, word, n) != 0)
        return fail(s, s->line, "invalid JSON: invalid literal (expected true, false or null)");
    s->pos += n;
    return UB_OK;
}

static int scan_value(scanner_t *s, int depth, ub_json_value_t *out);

static int scan_container(scanner_t *s, int depth, bool is_object) {
    const char close = is_object ? '}' : ']';
    const char *after_member = is_object ? "',' or '}'" : "',' or ']'";
    if (depth > UB_JSON_MAX_DEPTH)
        return fail(s, s->line, "invalid JSON: nesting deeper than %d levels", UB_JSON_MAX_DEPTH);
    s->pos++;
    skip_ws(s);
    if (s->pos < s->len && s->text[s->pos] == close) {
        s->pos++;
        return UB_OK;
    }
    for (;;) {
        ub_json_value_t member;
        int rc;
        skip_ws(s);
        if (is_object) {
            if (s->pos >= s->len || s->text[s->pos] != '"') return fail_found(s, "a string key");
            if ((rc = scan_string(s)) != UB_OK) return rc;
            skip_ws(s);
            if (s->pos >= s->len || s->text[s->pos] != ':') return fail_found(s, "':' after the key");
            s->pos++;
        }
        if ((rc = scan_value(s, depth + 1, &member)) != UB_OK) return rc;
        skip_ws(s);
        if (s->pos < s->len && s->text[s->pos] == close) {
            s->pos++;
            return UB_OK;
        }
        if (s->pos >= s->len || s->text[s->pos] != ',') return fail_found(s, after_member);
        s->pos++;
        skip_ws(s);
        if (s->pos < s->len && s->text[s->pos] == close)
            return fail(s, s->line, "invalid JSON: trailing ',' before '%c' (JSON does not allow one)", close);
    }
}

static int scan_value(scanner_t *s, int depth, ub_json_value_t *out) {
    skip_ws(s);
    if (s->pos >= s->len) return fail_found(s, "a value");
    out->start = s->pos;
    out->line = s->line;
    int rc;
    char c = s->text[s->pos];
    if (c == '{') {
        out->kind = UB_JSON_OBJECT;
        rc = scan_container(s, depth, true);
    } else if (c == '[') {
        out->kind = UB_JSON_ARRAY;
        rc = scan_container(s, depth, false);
    } else if (c == '"') {
        out->kind = UB_JSON_STRING;
        rc = scan_string(s);
    } else if (c == '-' || (c >= '0' && c <= '9')) {
        out->kind = UB_JSON_NUMBER;
        rc = scan_number(s);
    } else if (c == 't') {
        out->kind = UB_JSON_TRUE;
        rc = scan_literal(s, "true");
    } else if (c == 'f') {
        out->kind = UB_JSON_FALSE;
        rc = scan_literal(s, "false");
    } else if (c == 'n') {
        out->kind = UB_JSON_NULL;
        rc = scan_literal(s, "null");
    } else {
        return fail_found(s, "a value");
    }
    out->end = s->pos;
    return rc;
}

int ub_json_parse(ub_json_doc_t *doc, const char *text, size_t len, ub_json_value_t *root,
                  uint32_t *err_line, char *msg, size_t msg_cap) {
    scanner_t s = {.text = text, .len = len, .pos = 0, .line = 1, .msg = msg, .msg_cap = msg_cap, .err_line = 0};
    doc->text = text;
    doc->len = len;
    int rc = scan_value(&s, 1, root);
    if (rc == UB_OK) {
        skip_ws(&s);
        if (s.pos < s.len) rc = fail_found(&s, "end of file after the top-level value");
    }
    *err_line = s.err_line;
    return rc;
}

void ub_json_iter_begin(ub_json_iter_t *it, const ub_json_doc_t *doc, const ub_json_value_t *container) {
    it->doc = doc;
    it->pos = container->start + 1;
    it->line = container->line;
    it->is_object = container->kind == UB_JSON_OBJECT;
}

bool ub_json_iter_next(ub_json_iter_t *it, ub_json_value_t *key, ub_json_value_t *value) {
    scanner_t s = {.text = it->doc->text, .len = it->doc->len, .pos = it->pos, .line = it->line, .msg = NULL};
    skip_ws(&s);
    if (s.pos < s.len && s.text[s.pos] == ',') {
        s.pos++;
        skip_ws(&s);
    }
    if (s.pos >= s.len || s.text[s.pos] == '}' || s.text[s.pos] == ']') {
        it->pos = s.pos;
        it->line = s.line;
        return false;
    }
    if (it->is_object) {
        ub_json_value_t k = {.kind = UB_JSON_STRING, .start = s.pos, .line = s.line};
        (void)scan_string(&s);
        k.end = s.pos;
        if (key != NULL) *key = k;
        skip_ws(&s);
        s.pos++; /* ':' */
    }
    (void)scan_value(&s, 1, value);
    it->pos = s.pos;
    it->line = s.line;
    return true;
}

static size_t put_utf8(char *out, size_t cap, size_t n, unsigned long cp) {
    unsigned char b[4];
    size_t k;
    if (cp < 0x80) {
        b[0] = (unsigned char)cp;
        k = 1;
    } else if (cp < 0x800) {
        b[0] = (unsigned char)(0xC0 | (cp >> 6));
        b[1] = (unsigned char)(0x80 | (cp & 0x3F));
        k = 2;
    } else if (cp < 0x10000) {
        b[0] = (unsigned char)(0xE0 | (cp >> 12));
        b[1] = (unsigned char)(0x80 | ((cp >> 6) & 0x3F));
        b[2] = (unsigned char)(0x80 | (cp & 0x3F));
        k = 3;
    } else {
        b[0] = (unsigned char)(0xF0 | (cp >> 18));
        b[1] = (unsigned char)(0x80 | ((cp >> 12) & 0x3F));
        b[2] = (unsigned char)(0x80 | ((cp >> 6) & 0x3F));
        b[3] = (unsigned char)(0x80 | (cp & 0x3F));
        k = 4;
    }
    for (size_t i = 0; i < k; i++)
        if (n + i + 1 < cap) out[n + i] = (char)b[i];
    return n + k;
}

size_t ub_json_string(const ub_json_doc_t *doc, const ub_json_value_t *v, char *out, size_t cap) {
    const char *t = doc->text;
    size_t n = 0;
    size_t i = v->start + 1;
    size_t end = v->end - 1; /* closing quote */
    while (i < end) {
        char c = t[i];
        if (c != '\\') {
            if (n + 1 < cap) out[n] = c;
            n++;
            i++;
            continue;
        }
        char e = t[i + 1];
        i += 2;
        switch (e) {
        case 'b': c = '\b'; break;
        case 'f': c = '\f'; break;
        case 'n': c = '\n'; break;
        case 'r': c = '\r'; break;
        case 't': c = '\t'; break;
        case 'u': {
            unsigned long cp = (unsigned long)read_u4(t, doc->len, i);
            i += 4;
            if (cp >= 0xD800 && cp <= 0xDBFF) {
                unsigned long low = (unsigned long)read_u4(t, doc->len, i + 2);
                cp = 0x10000 + ((cp - 0xD800) << 10) + (low - 0xDC00);
                i += 6;
            }
            n = put_utf8(out, cap, n, cp);
            continue;
        }
        default: c = e; break; /* \" \\ \/ */
        }
        if (n + 1 < cap) out[n] = c;
        n++;
    }
    if (cap > 0) out[n < cap ? n : cap - 1] = '\0';
    return n;
}
