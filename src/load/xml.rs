//! Format-neutral scene tree with file positions.
//!
//! Any XML scene file (Nori's, Mitsuba's) is read into a tree of
//! [`SceneNode`]s: element tag, attributes, child elements and stray text,
//! each with the line and column where it starts. Nothing here knows what a
//! camera or a mesh is; the dialect modules give the tree its meaning.

/// A 1-based line and column (columns count characters, not bytes).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Pos {
    pub line: u32,
    pub col: u32,
}

impl Pos {
    pub const fn new(line: u32, col: u32) -> Pos {
        Pos { line, col }
    }
}

impl std::fmt::Display for Pos {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}:{}", self.line, self.col)
    }
}

/// One attribute of an element.
#[derive(Clone, Debug, PartialEq)]
pub struct Attribute {
    pub name: String,
    /// The value after XML normalisation (entities expanded, line breaks
    /// and tabs turned into spaces).
    pub value: String,
    /// Where the attribute's name starts.
    pub pos: Pos,
    /// Where the value starts (the first character inside the quotes).
    pub value_pos: Pos,
    /// The value as written in the file, kept only when it maps character
    /// for character onto `value`, so a token inside it can be located.
    raw: Option<String>,
}

impl Attribute {
    /// Replaces the value (e.g. after parameter substitution). Offsets in
    /// the new value no longer map onto the file, so positions inside it
    /// fall back to the start of the value.
    pub fn set_value(&mut self, value: String) {
        if self.value != value {
            self.value = value;
            self.raw = None;
        }
    }

    /// Position of the character at byte offset `offset` of `value`; the
    /// start of the value if the offset cannot be mapped back to the file
    /// (e.g. the value contains entity references).
    pub fn pos_in_value(&self, offset: usize) -> Pos {
        let Some(raw) = &self.raw else {
            return self.value_pos;
        };
        let mut pos = self.value_pos;
        for (i, c) in raw.char_indices() {
            if i >= offset {
                break;
            }
            if c == '\n' {
                pos.line += 1;
                pos.col = 1;
            } else {
                pos.col += 1;
            }
        }
        pos
    }
}

/// Character data that is not just whitespace.
#[derive(Clone, Debug, PartialEq)]
pub struct Text {
    pub text: String,
    pub pos: Pos,
}

/// One element of a scene file.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneNode {
    pub tag: String,
    /// Where the element starts (its `<`).
    pub pos: Pos,
    pub attributes: Vec<Attribute>,
    /// Child elements in document order.
    pub children: Vec<SceneNode>,
    /// Non-whitespace text directly inside the element, in document order.
    pub text: Vec<Text>,
}

impl SceneNode {
    pub fn attr(&self, name: &str) -> Option<&Attribute> {
        self.attributes.iter().find(|a| a.name == name)
    }

    pub fn attr_value(&self, name: &str) -> Option<&str> {
        self.attr(name).map(|a| a.value.as_str())
    }
}

/// A file that is not well-formed XML.
#[derive(Clone, Debug, PartialEq)]
pub struct XmlError {
    /// `None` only if the problem has no place in the file (e.g. it is empty).
    pub pos: Option<Pos>,
    pub message: String,
}

/// Parses a whole document into the tree of its root element.
pub fn parse(text: &str) -> Result<SceneNode, XmlError> {
    let opts = roxmltree::ParsingOptions {
        allow_dtd: false,
        ..Default::default()
    };
    let late = late_declaration(text);
    let text = late.as_deref().unwrap_or(text);
    let doc = match roxmltree::Document::parse_with_options(text, opts) {
        Ok(doc) => doc,
        Err(e) => return Err(describe_error(text, &e)),
    };
    let mapper = PosMapper::new(text);
    convert(&doc, &mapper, doc.root_element(), 0)
}

/// A copy of `text` with its XML declaration blanked out when blank
/// lines or spaces come before it (XML allows nothing there, but Nori's
/// and Mitsuba's parser, pugixml, skip it, and students' files have it);
/// spaces keep every line and column where it was. None when the
/// declaration is first or absent.
fn late_declaration(text: &str) -> Option<String> {
    let body = text.strip_prefix('\u{feff}').unwrap_or(text);
    let lead = body.len() - body.trim_start().len();
    if lead == 0 || !body[lead..].starts_with("<?xml") {
        return None;
    }
    let start = text.len() - body.len() + lead;
    let end = start + text[start..].find("?>")? + 2;
    let blank: String = text[start..end]
        .chars()
        .map(|c| if c == '\n' { '\n' } else { ' ' })
        .collect();
    Some(format!("{}{blank}{}", &text[..start], &text[end..]))
}

/// Deepest element nesting accepted (the tree is built recursively).
pub const MAX_DEPTH: usize = 256;

/// Turns byte offsets into line:col in O(log lines + distance from the
/// previous query), where roxmltree's `text_pos_at` rescans the text each
/// time. Columns count characters; a byte-order mark is not a column.
struct PosMapper<'t> {
    text: &'t str,
    line_starts: Vec<usize>,
    /// The last answer: (byte, pos), to count on from it.
    last: std::cell::Cell<(usize, Pos)>,
}

impl<'t> PosMapper<'t> {
    fn new(text: &'t str) -> Self {
        let mut line_starts = vec![0];
        line_starts.extend(
            text.bytes()
                .enumerate()
                .filter(|&(_, b)| b == b'\n')
                .map(|(i, _)| i + 1),
        );
        // A byte-order mark is skipped, not counted.
        let first = if text.starts_with('\u{feff}') { 3 } else { 0 };
        PosMapper {
            text,
            line_starts,
            last: std::cell::Cell::new((first, Pos::new(1, 1))),
        }
    }

    fn pos(&self, byte: usize) -> Pos {
        let mut byte = byte.min(self.text.len());
        while !self.text.is_char_boundary(byte) {
            byte -= 1;
        }
        let line = self.line_starts.partition_point(|&s| s <= byte);
        let line_start = self.line_starts[line - 1];
        let (last_byte, last_pos) = self.last.get();
        let (from, col0) = if last_pos.line as usize == line && last_byte <= byte {
            (last_byte, last_pos.col)
        } else {
            let bom = line == 1 && self.text.starts_with('\u{feff}');
            (line_start + if bom { 3 } else { 0 }, 1)
        };
        let from = from.min(byte);
        let col = col0 + self.text[from..byte].chars().count() as u32;
        let pos = Pos::new(line as u32, col);
        self.last.set((byte, pos));
        pos
    }
}

fn convert(
    doc: &roxmltree::Document,
    m: &PosMapper,
    node: roxmltree::Node,
    depth: usize,
) -> Result<SceneNode, XmlError> {
    if depth >= MAX_DEPTH {
        return Err(XmlError {
            pos: Some(m.pos(node.range().start)),
            message: format!("elements are nested more than {MAX_DEPTH} levels deep"),
        });
    }
    // Positions are asked for in document order, which keeps them cheap.
    let pos = m.pos(node.range().start);
    let input = doc.input_text();
    let attributes = node
        .attributes()
        .map(|a| {
            let vr = a.range_value();
            let raw = input
                .get(vr.clone())
                .filter(|r| !r.contains('&') && !r.contains('\r') && r.len() == a.value().len())
                .map(str::to_string);
            Attribute {
                name: a.name().to_string(),
                value: a.value().to_string(),
                pos: m.pos(a.range().start),
                value_pos: m.pos(vr.start),
                raw,
            }
        })
        .collect();
    let mut children = Vec::new();
    let mut text = Vec::new();
    for ch in node.children() {
        if ch.is_element() {
            children.push(convert(doc, m, ch, depth + 1)?);
        } else if ch.is_text() {
            let t = ch.text().unwrap_or("");
            if !t.trim().is_empty() {
                // Point at the first non-blank character.
                let lead = t.len() - t.trim_start().len();
                let start = ch.range().start;
                let pos = if input.get(start..start + lead) == Some(&t[..lead]) {
                    m.pos(start + lead)
                } else {
                    m.pos(start)
                };
                text.push(Text {
                    text: t.trim().to_string(),
                    pos,
                });
            }
        }
    }
    Ok(SceneNode {
        tag: node.tag_name().name().to_string(),
        pos,
        attributes,
        children,
        text,
    })
}

/// Byte offset of a roxmltree text position.
fn byte_offset(text: &str, pos: roxmltree::TextPos) -> usize {
    let mut line = 1;
    let mut start = 0;
    if pos.row > 1 {
        for (i, b) in text.bytes().enumerate() {
            if b == b'\n' {
                line += 1;
                if line == pos.row {
                    start = i + 1;
                    break;
                }
            }
        }
    }
    let rest = &text[start..];
    rest.char_indices()
        .nth(pos.col.saturating_sub(1) as usize)
        .map_or(text.len(), |(i, _)| start + i)
}

fn text_pos(text: &str, byte: usize) -> Pos {
    PosMapper::new(text).pos(byte)
}

fn describe_error(text: &str, e: &roxmltree::Error) -> XmlError {
    use roxmltree::Error as E;
    let at = |p: roxmltree::TextPos| {
        let byte = byte_offset(text, p);
        Some(text_pos(text, byte))
    };
    match e {
        E::UnexpectedCloseTag(expected, actual, p) => {
            let close = byte_offset(text, *p);
            let scan = scan_tags(text, close);
            let opened = scan
                .open
                .last()
                .filter(|(name, _)| name == expected)
                .map(|(_, b)| format!(" (opened at {})", text_pos(text, *b)))
                .unwrap_or_default();
            XmlError {
                pos: Some(text_pos(text, close)),
                message: format!(
                    "malformed XML: found </{actual}>, but <{expected}>{opened} is not closed yet"
                ),
            }
        }
        E::UnclosedRootNode | E::UnexpectedEndOfStream => {
            let scan = scan_tags(text, text.len());
            if let Some((what, b)) = scan.incomplete {
                XmlError {
                    pos: Some(text_pos(text, b)),
                    message: format!("malformed XML: this {what} is never finished"),
                }
            } else if let Some((name, b)) = scan.open.last() {
                XmlError {
                    pos: Some(text_pos(text, *b)),
                    message: format!(
                        "malformed XML: <{name}> is never closed (the file ends first)"
                    ),
                }
            } else {
                XmlError {
                    pos: Some(text_pos(text, text.len())),
                    message: "malformed XML: the file ends too early".into(),
                }
            }
        }
        E::NoRootNode => XmlError {
            pos: None,
            message: "malformed XML: the file contains no element".into(),
        },
        E::DtdDetected => XmlError {
            pos: text.find("<!DOCTYPE").map(|b| text_pos(text, b)),
            message: "document type declarations (<!DOCTYPE>) are not supported".into(),
        },
        E::NodesLimitReached | E::AttributesLimitReached | E::NamespacesLimitReached => XmlError {
            pos: None,
            message: format!("malformed XML: {e}"),
        },
        other => {
            // roxmltree's messages end with " at line:col"; we print the
            // position in front instead.
            let msg = other.to_string();
            let p = other.pos();
            let suffix = format!(" at {p}");
            let msg = msg.strip_suffix(&suffix).unwrap_or(&msg).to_string();
            let msg = msg.replace(&format!(" at {p} "), " ");
            XmlError {
                pos: at(p),
                message: format!("malformed XML: {msg}"),
            }
        }
    }
}

/// Open elements (name, byte offset of `<`) before byte `stop`, and the
/// construct left unfinished at the end, if any.
struct TagScan {
    open: Vec<(String, usize)>,
    incomplete: Option<(&'static str, usize)>,
}

/// A forgiving scan of the tag structure, used only to explain errors.
fn scan_tags(text: &str, stop: usize) -> TagScan {
    let b = text.as_bytes();
    let stop = stop.min(b.len());
    let mut open: Vec<(String, usize)> = Vec::new();
    let mut i = 0;
    let find =
        |from: usize, pat: &str| text.get(from..).and_then(|s| s.find(pat)).map(|j| from + j);
    let name_at = |from: usize| -> String {
        text.get(from..)
            .unwrap_or("")
            .chars()
            .take_while(|c| !c.is_whitespace() && !matches!(c, '/' | '>' | '<'))
            .collect()
    };
    while i < stop {
        if b[i] != b'<' {
            i += 1;
            continue;
        }
        let start = i;
        let rest = &text[i..];
        let (what, end) = if rest.starts_with("<!--") {
            ("comment", find(i + 4, "-->").map(|j| j + 3))
        } else if rest.starts_with("<![CDATA[") {
            ("CDATA section", find(i + 9, "]]>").map(|j| j + 3))
        } else if rest.starts_with("<?") {
            ("processing instruction", find(i + 2, "?>").map(|j| j + 2))
        } else if rest.starts_with("<!") {
            ("declaration", find(i + 2, ">").map(|j| j + 1))
        } else if rest.starts_with("</") {
            let name = name_at(i + 2);
            let end = find(i + 2, ">").map(|j| j + 1);
            if end.is_some() {
                if let Some(k) = open.iter().rposition(|(n, _)| *n == name) {
                    open.truncate(k);
                }
            }
            ("closing tag", end)
        } else {
            // Start tag: find its '>' outside quotes.
            let name = name_at(i + 1);
            let mut j = i + 1;
            let mut quote = None;
            let mut end = None;
            while j < b.len() {
                let c = b[j];
                match quote {
                    Some(q) if c == q => quote = None,
                    Some(_) => {}
                    None if c == b'"' || c == b'\'' => quote = Some(c),
                    None if c == b'>' => {
                        end = Some(j + 1);
                        if b[j - 1] != b'/' {
                            open.push((name.clone(), start));
                        }
                        break;
                    }
                    None => {}
                }
                j += 1;
            }
            ("tag", end)
        };
        match end {
            Some(e) => i = e,
            None => {
                return TagScan {
                    open,
                    incomplete: Some((what, start)),
                }
            }
        }
    }
    TagScan {
        open,
        incomplete: None,
    }
}

/// `<camera type="perspective">`, or `<scene>` for an untyped element.
pub(crate) fn describe(node: &SceneNode) -> String {
    match node.attr_value("type") {
        Some(t) => format!("<{} type=\"{t}\">", node.tag),
        None => format!("<{}>", node.tag),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn positions_of_elements_and_attributes() {
        let doc = "<a>\n  <b x=\"1 2\"\n     y='3'/>\n</a>";
        let root = parse(doc).unwrap();
        assert_eq!(root.tag, "a");
        assert_eq!(root.pos, Pos::new(1, 1));
        let b = &root.children[0];
        assert_eq!(b.pos, Pos::new(2, 3));
        assert_eq!(b.attr("x").unwrap().pos, Pos::new(2, 6));
        assert_eq!(b.attr("x").unwrap().value_pos, Pos::new(2, 9));
        assert_eq!(b.attr("x").unwrap().pos_in_value(2), Pos::new(2, 11));
        assert_eq!(b.attr("y").unwrap().value_pos, Pos::new(3, 9));
    }

    #[test]
    fn token_position_across_lines() {
        let doc = "<a v=\"1,\n  2\"/>";
        let root = parse(doc).unwrap();
        let v = root.attr("v").unwrap();
        assert_eq!(v.value, "1,   2");
        assert_eq!(v.pos_in_value(5), Pos::new(2, 3));
    }

    #[test]
    fn unclosed_element_is_located() {
        let doc = "<a>\n  <b>\n</a>\n";
        let e = parse(doc).unwrap_err();
        assert_eq!(e.pos, Some(Pos::new(3, 1)));
        assert!(e.message.contains("<b> (opened at 2:3)"), "{}", e.message);
        let e = parse("<a>\n <b>\n").unwrap_err();
        assert_eq!(e.pos, Some(Pos::new(2, 2)), "{}", e.message);
        let e = parse("<a>\n <b x=\"1").unwrap_err();
        assert_eq!(e.pos, Some(Pos::new(2, 2)), "{}", e.message);
    }

    #[test]
    fn deep_nesting_is_an_error_not_a_stack_overflow() {
        let n = 100_000;
        let doc = "<a>".repeat(n) + &"</a>".repeat(n);
        let e = parse(&doc).unwrap_err();
        assert_eq!(e.pos, Some(Pos::new(1, 3 * MAX_DEPTH as u32 + 1)));
        assert!(e.message.contains("nested"));
    }

    #[test]
    fn positions_agree_with_roxmltree() {
        let text = "<a>\n  <b x=\"\u{e9}\u{e9}\" y='1'>t\u{1f600}xt</b>\r\n\n<c/></a>\n";
        let doc = roxmltree::Document::parse(text).unwrap();
        let m = PosMapper::new(text);
        let bytes: Vec<usize> = (0..=text.len())
            .filter(|&b| text.is_char_boundary(b))
            .collect();
        // In order (uses the cursor), then backwards (does not).
        for &b in bytes.iter().chain(bytes.iter().rev()) {
            let r = doc.text_pos_at(b);
            assert_eq!(m.pos(b), Pos::new(r.row, r.col), "byte {b}");
        }
    }

    #[test]
    fn stray_text_is_kept() {
        let root = parse("<a>\n  hello <b/></a>").unwrap();
        assert_eq!(root.text[0].text, "hello");
        assert_eq!(root.text[0].pos, Pos::new(2, 3));
    }

    #[test]
    fn byte_order_mark_does_not_shift_columns() {
        let root = parse("\u{feff}<a><b/></a>").unwrap();
        assert_eq!(root.pos, Pos::new(1, 1));
        assert_eq!(root.children[0].pos, Pos::new(1, 4));
    }
}
