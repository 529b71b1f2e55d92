//! Just enough HTTP/1.1 for the preview page: one request per connection
//! (`Connection: close`), bounded header size, no chunked bodies. Malformed
//! input gives an error response, never a panic.

use std::io::{self, Read, Write};

/// Longest request head (request line and headers) accepted.
pub const MAX_HEAD: usize = 16 * 1024;

/// Longest request body read (and discarded: no route takes a body).
pub const MAX_BODY: usize = 64 * 1024;

/// A parsed request head.
#[derive(Debug, PartialEq, Eq)]
pub struct Request {
    pub method: String,
    /// The path, without the query string (not percent-decoded).
    pub path: String,
    /// Query parameters, percent-decoded, in order.
    pub query: Vec<(String, String)>,
    /// Header names lower-cased, values trimmed.
    pub headers: Vec<(String, String)>,
}

impl Request {
    pub fn header(&self, name: &str) -> Option<&str> {
        self.headers
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_str())
    }

    pub fn param(&self, name: &str) -> Option<&str> {
        self.query
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_str())
    }
}

/// A response to send, with the connection closed afterwards.
#[derive(Debug)]
pub struct Response {
    pub status: u16,
    pub content_type: &'static str,
    pub body: Vec<u8>,
    pub extra_headers: Vec<(&'static str, String)>,
}

impl Response {
    pub fn new(status: u16, content_type: &'static str, body: impl Into<Vec<u8>>) -> Response {
        Response {
            status,
            content_type,
            body: body.into(),
            extra_headers: Vec::new(),
        }
    }

    /// A plain-text response, e.g. for errors.
    pub fn text(status: u16, message: &str) -> Response {
        let mut body = message.to_string();
        body.push('\n');
        Response::new(status, "text/plain; charset=utf-8", body)
    }

    pub fn json(status: u16, body: String) -> Response {
        Response::new(status, "application/json", body)
    }

    pub fn with_header(mut self, name: &'static str, value: impl Into<String>) -> Response {
        self.extra_headers.push((name, value.into()));
        self
    }

    /// Writes the response; for HEAD requests only the head.
    pub fn write_to(&self, out: &mut impl Write, head_only: bool) -> io::Result<()> {
        let mut head = format!(
            "HTTP/1.1 {} {}\r\nContent-Type: {}\r\nContent-Length: {}\r\n\
             Cache-Control: no-store\r\nX-Content-Type-Options: nosniff\r\nConnection: close\r\n",
            self.status,
            reason(self.status),
            self.content_type,
            self.body.len()
        );
        for (name, value) in &self.extra_headers {
            head.push_str(name);
            head.push_str(": ");
            head.push_str(value);
            head.push_str("\r\n");
        }
        head.push_str("\r\n");
        out.write_all(head.as_bytes())?;
        if !head_only {
            out.write_all(&self.body)?;
        }
        out.flush()
    }
}

fn reason(status: u16) -> &'static str {
    match status {
        200 => "OK",
        400 => "Bad Request",
        403 => "Forbidden",
        404 => "Not Found",
        405 => "Method Not Allowed",
        409 => "Conflict",
        413 => "Payload Too Large",
        431 => "Request Header Fields Too Large",
        500 => "Internal Server Error",
        501 => "Not Implemented",
        503 => "Service Unavailable",
        505 => "HTTP Version Not Supported",
        _ => "Unknown",
    }
}

/// Why a request could not be read.
#[derive(Debug)]
pub enum ReadError {
    /// The peer closed the connection or timed out before sending a whole
    /// head: nothing to answer.
    Closed,
    /// A malformed or unsupported request: answer with this.
    Bad(Response),
}

/// Reads and parses one request head, then reads and discards a body of at
/// most [`MAX_BODY`] bytes (so closing the socket does not reset it while
/// the client still sends).
pub fn read_request(stream: &mut impl Read) -> Result<Request, ReadError> {
    let mut buf = Vec::with_capacity(1024);
    let mut chunk = [0u8; 2048];
    let (head_end, blank_len) = loop {
        if let Some(end) = head_end(&buf) {
            break end;
        }
        if buf.len() > MAX_HEAD {
            return Err(ReadError::Bad(Response::text(
                431,
                "request head too large",
            )));
        }
        match stream.read(&mut chunk) {
            Ok(0) => {
                return if buf.iter().all(|b| b.is_ascii_whitespace()) {
                    Err(ReadError::Closed)
                } else {
                    Err(ReadError::Bad(Response::text(400, "incomplete request")))
                }
            }
            Ok(n) => buf.extend_from_slice(&chunk[..n]),
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(_) => return Err(ReadError::Closed),
        }
    };
    if head_end > MAX_HEAD {
        return Err(ReadError::Bad(Response::text(
            431,
            "request head too large",
        )));
    }
    let request = parse_head(&buf[..head_end]).map_err(ReadError::Bad)?;
    if request.header("transfer-encoding").is_some() {
        return Err(ReadError::Bad(Response::text(
            501,
            "transfer encodings are not supported",
        )));
    }
    let length = match request.header("content-length") {
        None => 0,
        Some(v) => v
            .parse::<usize>()
            .map_err(|_| ReadError::Bad(Response::text(400, "bad Content-Length")))?,
    };
    if length > MAX_BODY {
        return Err(ReadError::Bad(Response::text(
            413,
            "request body too large",
        )));
    }
    let mut have = buf.len() - (head_end + blank_len);
    while have < length {
        match stream.read(&mut chunk) {
            Ok(0) => break,
            Ok(n) => have += n,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(_) => break,
        }
    }
    Ok(request)
}

/// Where the head ends: at the first empty line, with lines ended by CRLF
/// or (as RFC 9112 2.2 lets a server accept) a bare LF. Returns the end of
/// the head and the length of the line breaks that follow it.
fn head_end(buf: &[u8]) -> Option<(usize, usize)> {
    (0..buf.len()).find_map(|i| {
        if buf[i] != b'\n' {
            return None;
        }
        let empty_line = match &buf[i + 1..] {
            [b'\n', ..] => 1,
            [b'\r', b'\n', ..] => 2,
            _ => return None,
        };
        let start = if i > 0 && buf[i - 1] == b'\r' {
            i - 1
        } else {
            i
        };
        Some((start, i + 1 + empty_line - start))
    })
}

/// Parses the request line and headers (without the blank line).
pub fn parse_head(head: &[u8]) -> Result<Request, Response> {
    let bad = |m: &str| Response::text(400, m);
    let text = std::str::from_utf8(head).map_err(|_| bad("request head is not UTF-8"))?;
    let mut lines = text.split('\n').map(|l| l.strip_suffix('\r').unwrap_or(l));
    // Tolerate blank lines before the request line (RFC 9112, 2.2).
    let line = lines
        .by_ref()
        .find(|l| !l.is_empty())
        .ok_or_else(|| bad("empty request"))?;
    let mut parts = line.split(' ');
    let (Some(method), Some(target), Some(version), None) =
        (parts.next(), parts.next(), parts.next(), parts.next())
    else {
        return Err(bad("malformed request line"));
    };
    if method.is_empty() || !method.bytes().all(|b| b.is_ascii_uppercase()) {
        return Err(bad("malformed method"));
    }
    if !version.starts_with("HTTP/1.") {
        return Err(Response::text(505, "only HTTP/1.x is supported"));
    }
    if !target.starts_with('/') {
        return Err(bad("request target must be a path"));
    }
    let (path, query) = target.split_once('?').unwrap_or((target, ""));
    let query = parse_query(query).ok_or_else(|| bad("malformed query string"))?;
    let mut headers = Vec::new();
    for l in lines {
        let (name, value) = l.split_once(':').ok_or_else(|| bad("malformed header"))?;
        if name.is_empty() || name.bytes().any(|b| b.is_ascii_whitespace()) {
            return Err(bad("malformed header name"));
        }
        headers.push((name.to_ascii_lowercase(), value.trim().to_string()));
    }
    Ok(Request {
        method: method.to_string(),
        path: path.to_string(),
        query,
        headers,
    })
}

/// `a=1&b=x%20y` to pairs; `None` for bad percent escapes.
pub fn parse_query(q: &str) -> Option<Vec<(String, String)>> {
    let mut out = Vec::new();
    for pair in q.split('&').filter(|p| !p.is_empty()) {
        let (k, v) = pair.split_once('=').unwrap_or((pair, ""));
        out.push((percent_decode(k)?, percent_decode(v)?));
    }
    Some(out)
}

/// Decodes `%XX` escapes and `+` (a space, as in HTML forms); `None` for a
/// bad escape or a result that is not UTF-8.
pub fn percent_decode(s: &str) -> Option<String> {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        match bytes[i] {
            b'%' => {
                let hex = bytes.get(i + 1..i + 3)?;
                let hex = std::str::from_utf8(hex).ok()?;
                out.push(u8::from_str_radix(hex, 16).ok()?);
                i += 3;
            }
            b'+' => {
                out.push(b' ');
                i += 1;
            }
            b => {
                out.push(b);
                i += 1;
            }
        }
    }
    String::from_utf8(out).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_a_request() {
        let raw =
            b"GET /image.png?exposure=-1.5&v=3 HTTP/1.1\r\nHost: 127.0.0.1:80\r\nX-A:  b \r\n\r\n";
        let r = read_request(&mut &raw[..]).unwrap();
        assert_eq!(r.method, "GET");
        assert_eq!(r.path, "/image.png");
        assert_eq!(r.param("exposure"), Some("-1.5"));
        assert_eq!(r.param("v"), Some("3"));
        assert_eq!(r.header("host"), Some("127.0.0.1:80"));
        assert_eq!(r.header("x-a"), Some("b"));
    }

    #[test]
    fn malformed_requests_are_errors() {
        let cases: &[&[u8]] = &[
            b"garbage\r\n\r\n",
            b"GET\r\n\r\n",
            b"GET / HTTP/1.1 extra\r\n\r\n",
            b"get / HTTP/1.1\r\n\r\n",
            b"GET http://x/ HTTP/1.1\r\n\r\n",
            b"GET / SPDY/3\r\n\r\n",
            b"GET /?a=%zz HTTP/1.1\r\n\r\n",
            b"GET / HTTP/1.1\r\nno colon\r\n\r\n",
            b"GET / HTTP/1.1\r\nContent-Length: -1\r\n\r\n",
            b"GET / HTTP/1.1\r\nContent-Length: 99999999999\r\n\r\n",
            b"POST / HTTP/1.1\r\nTransfer-Encoding: chunked\r\n\r\n",
            b"GET /\xff HTTP/1.1\r\n\r\n",
            b"GET / HTTP/1.1\r\n",
        ];
        for raw in cases {
            match read_request(&mut &raw[..]) {
                Err(ReadError::Bad(r)) => assert!(r.status >= 400, "{raw:?}"),
                other => panic!("{:?}: {other:?}", String::from_utf8_lossy(raw)),
            }
        }
        assert!(matches!(
            read_request(&mut &b""[..]),
            Err(ReadError::Closed)
        ));
        let huge = vec![b'a'; MAX_HEAD + 10];
        match read_request(&mut &huge[..]) {
            Err(ReadError::Bad(r)) => assert_eq!(r.status, 431),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn bare_lf_requests_are_read_like_crlf_ones() {
        for raw in [
            &b"GET /status?x=1 HTTP/1.1\nHost: 127.0.0.1:80\n\n"[..],
            b"GET /status?x=1 HTTP/1.1\r\nHost: 127.0.0.1:80\n\r\n",
            b"GET /status?x=1 HTTP/1.1\r\nHost: 127.0.0.1:80\r\n\r\n",
        ] {
            let req = read_request(&mut &raw[..]).unwrap();
            assert_eq!(req.path, "/status");
            assert_eq!(req.header("host"), Some("127.0.0.1:80"));
        }
        assert_eq!(head_end(b"A\r\n\r\nbody"), Some((1, 4)));
        assert_eq!(head_end(b"A\n\nbody"), Some((1, 2)));
        assert_eq!(head_end(b"A\r\nB\r\n"), None);
    }

    #[test]
    fn percent_decoding() {
        assert_eq!(percent_decode("a%2Bb+c").as_deref(), Some("a+b c"));
        assert_eq!(percent_decode("%"), None);
        assert_eq!(percent_decode("%4"), None);
        assert_eq!(percent_decode("%ff"), None);
    }

    #[test]
    fn json_escapes() {}

    #[test]
    fn responses_have_length_and_close() {
        let mut out = Vec::new();
        Response::text(404, "nope")
            .with_header("Allow", "GET")
            .write_to(&mut out, false)
            .unwrap();
        let s = String::from_utf8(out).unwrap();
        assert!(s.starts_with("HTTP/1.1 404 Not Found\r\n"), "{s}");
        assert!(s.contains("Content-Length: 5\r\n"));
        assert!(s.contains("Connection: close\r\n"));
        assert!(s.contains("Allow: GET\r\n"));
        assert!(s.ends_with("\r\n\r\nnope\n"));
    }
}
