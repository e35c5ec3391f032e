//! A small JSON reader for the protective parser (`parse.rs`): it reads
//! one object from a byte offset of a reply, keeping each top-level field's
//! value (nested ones are only validated) and, on failure, where and why it
//! stopped. serde_json is not used here because it rejects trailing commas,
//! and an overflowing number (1e309) makes the whole document an error
//! instead of one out-of-range field. Numbers are kept as their text and
//! read with Rust's exact `f64` parsing ([`Val::number`]).

/// serde_json's recursion limit.
pub(super) const MAX_DEPTH: usize = 128;

/// A top-level field value; nested values are only validated.
#[derive(Debug)]
pub(super) enum Val<'a> {
    Null,
    Str(String),
    /// Raw JSON number text (or `NaN` / `Infinity` / `-Infinity`).
    Num(&'a str),
    /// Boolean, array or object, as raw JSON text.
    Other(&'a str),
}

impl Val<'_> {
    /// The value as a number: a JSON number, or a string holding only a
    /// number (models quote numbers). Rust's float parser is correctly
    /// rounded, so a serialised f64 reads back bit-exactly; out-of-range
    /// exponents give ±inf, and "NaN" / "inf" parse too, so a caller's range
    /// check sees them.
    pub(super) fn number(&self) -> Option<f64> {
        match self {
            Val::Num(raw) => raw.parse::<f64>().ok(),
            Val::Str(s) => s.trim().parse::<f64>().ok(),
            Val::Null | Val::Other(_) => None,
        }
    }

    /// The value as quoted in error messages.
    pub(super) fn text(&self) -> &str {
        match self {
            Val::Null => "null",
            Val::Str(s) => s,
            Val::Num(raw) | Val::Other(raw) => raw,
        }
    }
}

#[derive(Debug, Clone)]
pub(super) struct Fail {
    /// Where the attempt began (set by the scanner).
    pub(super) start: usize,
    /// Byte offset of the offending input.
    pub(super) pos: usize,
    /// The input ended before the value did.
    pub(super) eof: bool,
    pub(super) what: &'static str,
}

pub(super) struct Reader<'a, 'w> {
    pub(super) s: &'a str,
    pub(super) b: &'a [u8],
    pub(super) pos: usize,
    /// Positions of every `{` read as an object start.
    pub(super) object_starts: &'w mut Vec<usize>,
}

impl<'a> Reader<'a, '_> {
    fn fail(&self, what: &'static str) -> Fail {
        Fail { start: 0, pos: self.pos, eof: self.pos >= self.b.len(), what }
    }

    fn peek(&self) -> Option<u8> {
        self.b.get(self.pos).copied()
    }

    fn eat(&mut self, c: u8) -> bool {
        let hit = self.peek() == Some(c);
        if hit {
            self.pos += 1;
        }
        hit
    }

    pub(super) fn ws(&mut self) {
        while matches!(self.peek(), Some(b' ' | b'\t' | b'\n' | b'\r')) {
            self.pos += 1;
        }
    }

    fn slice(&self, from: usize) -> &'a str {
        self.s.get(from..self.pos).unwrap_or_default()
    }

    /// The object at `pos`, keeping its top-level fields.
    pub(super) fn top_object(&mut self) -> Result<Vec<(String, Val<'a>)>, Fail> {
        let mut fields = Vec::new();
        self.object(1, Some(&mut fields))?;
        Ok(fields)
    }

    /// Any value at `pos` inside a container at `depth`; validated only.
    pub(super) fn value(&mut self, depth: usize) -> Result<(), Fail> {
        match self.peek() {
            Some(b'{') => self.object(depth + 1, None),
            Some(b'[') => self.array(depth + 1),
            Some(b'"') => self.string(false).map(drop),
            Some(b't') => self.literal("true"),
            Some(b'f') => self.literal("false"),
            Some(b'n') => self.literal("null"),
            Some(b'-' | b'0'..=b'9' | b'N' | b'I') => self.number().map(drop),
            _ => Err(self.fail("expected a value")),
        }
    }

    /// A top-level field value, kept for validation.
    fn field_value(&mut self, depth: usize) -> Result<Val<'a>, Fail> {
        let start = self.pos;
        match self.peek() {
            Some(b'"') => self.string(true).map(Val::Str),
            Some(b'n') => self.literal("null").map(|()| Val::Null),
            Some(b'-' | b'0'..=b'9' | b'N' | b'I') => self.number().map(Val::Num),
            _ => {
                self.value(depth)?;
                Ok(Val::Other(self.slice(start)))
            }
        }
    }

    fn object(&mut self, depth: usize, mut fields: Option<&mut Vec<(String, Val<'a>)>>) -> Result<(), Fail> {
        if depth > MAX_DEPTH {
            return Err(self.fail("nesting too deep"));
        }
        self.object_starts.push(self.pos);
        self.pos += 1;
        self.ws();
        if self.eat(b'}') {
            return Ok(());
        }
        loop {
            if self.peek() != Some(b'"') {
                return Err(self.fail("expected a string key"));
            }
            let key = self.string(fields.is_some())?;
            self.ws();
            if !self.eat(b':') {
                return Err(self.fail("expected ':' after a key"));
            }
            self.ws();
            match fields.as_deref_mut() {
                Some(fields) => {
                    let v = self.field_value(depth)?;
                    fields.push((key, v));
                }
                None => self.value(depth)?,
            }
            self.ws();
            if self.eat(b',') {
                self.ws();
                // Trailing comma: a common slip, harmless to accept.
                if self.eat(b'}') {
                    return Ok(());
                }
            } else if self.eat(b'}') {
                return Ok(());
            } else {
                return Err(self.fail("expected ',' or '}'"));
            }
        }
    }

    fn array(&mut self, depth: usize) -> Result<(), Fail> {
        if depth > MAX_DEPTH {
            return Err(self.fail("nesting too deep"));
        }
        self.pos += 1;
        self.ws();
        if self.eat(b']') {
            return Ok(());
        }
        loop {
            self.value(depth)?;
            self.ws();
            if self.eat(b',') {
                self.ws();
                if self.eat(b']') {
                    return Ok(());
                }
            } else if self.eat(b']') {
                return Ok(());
            } else {
                return Err(self.fail("expected ',' or ']'"));
            }
        }
    }

    fn literal(&mut self, word: &'static str) -> Result<(), Fail> {
        let rest = self.b.get(self.pos..).unwrap_or_default();
        if rest.starts_with(word.as_bytes()) {
            self.pos += word.len();
            Ok(())
        } else if word.as_bytes().starts_with(rest) {
            // Cut off mid-word.
            self.pos = self.b.len();
            Err(self.fail("unexpected end of input"))
        } else {
            Err(self.fail("invalid literal"))
        }
    }

    /// A JSON number (or a `NaN` / `Infinity` token), as raw text.
    fn number(&mut self) -> Result<&'a str, Fail> {
        let start = self.pos;
        let rest = self.b.get(self.pos..).unwrap_or_default();
        for token in ["NaN", "Infinity", "-Infinity"] {
            if rest.starts_with(token.as_bytes()) {
                self.pos += token.len();
                return Ok(self.slice(start));
            }
        }
        self.eat(b'-');
        match self.peek() {
            Some(b'0') => self.pos += 1,
            Some(b'1'..=b'9') => self.digits(),
            _ => return Err(self.fail("expected a digit")),
        }
        if self.eat(b'.') {
            self.digits1()?;
        }
        if matches!(self.peek(), Some(b'e' | b'E')) {
            self.pos += 1;
            if !self.eat(b'+') {
                self.eat(b'-');
            }
            self.digits1()?;
        }
        Ok(self.slice(start))
    }

    fn digits(&mut self) {
        while matches!(self.peek(), Some(b'0'..=b'9')) {
            self.pos += 1;
        }
    }

    fn digits1(&mut self) -> Result<(), Fail> {
        if !matches!(self.peek(), Some(b'0'..=b'9')) {
            return Err(self.fail("expected a digit"));
        }
        self.digits();
        Ok(())
    }

    /// A string at `pos` (which holds the opening quote); decoded only when
    /// asked, to keep validation allocation-free.
    fn string(&mut self, decode: bool) -> Result<String, Fail> {
        self.pos += 1;
        let mut out = String::new();
        let mut run = self.pos;
        loop {
            match self.peek() {
                None => return Err(self.fail("unterminated string")),
                Some(b'"') => {
                    if decode {
                        out.push_str(self.slice(run));
                    }
                    self.pos += 1;
                    return Ok(out);
                }
                Some(b'\\') => {
                    if decode {
                        out.push_str(self.slice(run));
                    }
                    self.pos += 1;
                    let escaped = match self.peek() {
                        None => return Err(self.fail("unterminated string")),
                        Some(b'u') => {
                            self.pos += 1;
                            self.unicode_escape()?
                        }
                        Some(c) => {
                            let ch = match c {
                                b'"' => '"',
                                b'\\' => '\\',
                                b'/' => '/',
                                b'b' => '\u{8}',
                                b'f' => '\u{c}',
                                b'n' => '\n',
                                b'r' => '\r',
                                b't' => '\t',
                                _ => return Err(self.fail("invalid escape")),
                            };
                            self.pos += 1;
                            ch
                        }
                    };
                    if decode {
                        out.push(escaped);
                    }
                    run = self.pos;
                }
                // Raw control characters are invalid JSON but models emit raw
                // newlines in long reasoning; accept them.
                Some(_) => self.pos += 1,
            }
        }
    }

    /// The four hex digits after `\u` (and a low surrogate escape after a
    /// high one). Broken surrogates become U+FFFD rather than errors.
    fn unicode_escape(&mut self) -> Result<char, Fail> {
        let hi = self.hex4()?;
        let code = match hi {
            0xD800..=0xDBFF => {
                if self.b.get(self.pos) == Some(&b'\\') && self.b.get(self.pos + 1) == Some(&b'u') {
                    let save = self.pos;
                    self.pos += 2;
                    match self.hex4()? {
                        lo @ 0xDC00..=0xDFFF => 0x10000 + ((hi - 0xD800) << 10) + (lo - 0xDC00),
                        _ => {
                            self.pos = save;
                            0xFFFD
                        }
                    }
                } else {
                    0xFFFD
                }
            }
            code => code,
        };
        Ok(char::from_u32(code).unwrap_or('\u{FFFD}'))
    }

    fn hex4(&mut self) -> Result<u32, Fail> {
        let mut code = 0u32;
        for _ in 0..4 {
            let digit = match self.peek() {
                None => return Err(self.fail("unterminated string")),
                Some(c) => (c as char).to_digit(16).ok_or_else(|| self.fail("invalid \\u escape"))?,
            };
            code = code * 16 + digit;
            self.pos += 1;
        }
        Ok(code)
    }
}
