//! A small, dependency-free Markdown → HTML converter for the verification report: the
//! subset the report writes — ATX headings, paragraphs, pipe tables, fenced code,
//! bullet lists, inline code, bold, emphasis, links — with every image that links an
//! `.svg` file replaced by that file's contents, and every image that links an `.html`
//! page (a [`constraint_scene::viewer`] replay) embedded as a sandboxed frame holding that page, so
//! the page is self-contained.
//!
//! The output depends only on the input and the SVG files (no dates, no hashing
//! iteration order): the same report converts to the same bytes.

use std::fmt::Write as _;
use std::path::Path;

pub use constraint_scene::viewer::escape;

const STYLE: &str = "body{font-family:sans-serif;max-width:1200px;margin:2em auto;padding:0 1em;line-height:1.45;color:#222}\
table{border-collapse:collapse;margin:1em 0;font-size:90%}\
th,td{border:1px solid #bbb;padding:3px 8px;text-align:left}\
th{background:#eee}\
code{background:#f3f3f3;padding:0 3px}\
pre{background:#f6f6f6;padding:8px;overflow-x:auto}\
pre code{background:none;padding:0}\
figure{margin:1em 0}\
figure svg{max-width:100%;height:auto}\
figcaption{font-size:85%;color:#555}\
details{margin:0 0 1em 0}\
summary{cursor:pointer;color:#345}\
.missing{color:#a00}";

/// Converts `md` to a complete HTML page titled `title`. `load_svg(path)` returns the
/// contents of the image file `path` as written in the Markdown (`None`: missing; the
/// page then says so where the chart would be).
///
/// Headings get the ids of [`headings`] (unique). A table that follows a chart in the
/// same section (after the image, before the next heading) repeats the chart's data: it
/// is folded under it, in `<details>` with a summary line giving its row count.
pub fn to_html(md: &str, title: &str, load_svg: &dyn Fn(&str) -> Option<String>) -> String {
    let mut body = String::new();
    let lines: Vec<&str> = md.lines().collect();
    let mut ids = headings(md).into_iter().map(|h| h.id);
    let mut after_chart = false;
    let mut i = 0;
    let mut para: Vec<&str> = Vec::new();
    let flush = |para: &mut Vec<&str>, body: &mut String| {
        if !para.is_empty() {
            let text = para.join("\n");
            let _ = writeln!(body, "<p>{}</p>", inline(&text));
            para.clear();
        }
    };
    while i < lines.len() {
        let line = lines[i];
        let t = line.trim();
        if t.is_empty() {
            flush(&mut para, &mut body);
            i += 1;
        } else if let Some(fence) = t.strip_prefix("```") {
            flush(&mut para, &mut body);
            let lang = fence.trim();
            let mut code = String::new();
            i += 1;
            while i < lines.len() && !lines[i].trim_start().starts_with("```") {
                code.push_str(lines[i]);
                code.push('\n');
                i += 1;
            }
            i += 1; // closing fence (or end of input)
            let class = if lang.is_empty() {
                String::new()
            } else {
                format!(r#" class="language-{}""#, escape(lang))
            };
            let _ = writeln!(body, "<pre><code{class}>{}</code></pre>", escape(&code));
        } else if let Some((level, text)) = heading(t) {
            flush(&mut para, &mut body);
            after_chart = false;
            let id = ids.next().unwrap_or_else(|| slug(text));
            let _ = writeln!(body, r#"<h{level} id="{id}">{}</h{level}>"#, inline(text));
            i += 1;
        } else if t.starts_with('|') {
            flush(&mut para, &mut body);
            let start = i;
            while i < lines.len() && lines[i].trim().starts_with('|') {
                i += 1;
            }
            let rows = &lines[start..i];
            if after_chart {
                let header = rows.len() >= 2 && is_separator(rows[1]);
                let n = rows.len() - if header { 2 } else { 0 };
                let _ = writeln!(
                    body,
                    "<details>\n<summary>Table: the chart's data, {n} row(s)</summary>"
                );
                table(rows, &mut body);
                body.push_str("</details>\n");
            } else {
                table(rows, &mut body);
            }
        } else if let Some((alt, src)) = lone_image(t) {
            flush(&mut para, &mut body);
            figure(alt, src, load_svg, &mut body);
            after_chart = !src.ends_with(".html");
            i += 1;
        } else if t.starts_with("- ") || t.starts_with("* ") {
            flush(&mut para, &mut body);
            body.push_str("<ul>\n");
            while i < lines.len() {
                let l = lines[i].trim();
                if let Some(item) = l.strip_prefix("- ").or_else(|| l.strip_prefix("* ")) {
                    let _ = writeln!(body, "<li>{}</li>", inline(item));
                } else if !l.is_empty() && lines[i].starts_with("  ") {
                    // Continuation of the previous item.
                    if body.ends_with("</li>\n") {
                        body.truncate(body.len() - "</li>\n".len());
                        let _ = writeln!(body, " {}</li>", inline(l));
                    }
                } else {
                    break;
                }
                i += 1;
            }
            body.push_str("</ul>\n");
        } else {
            para.push(t);
            i += 1;
        }
    }
    flush(&mut para, &mut body);
    format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>{}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n{body}</body>\n</html>\n",
        escape(title)
    )
}

/// Converts the Markdown file `md_path` to `html_path`, inlining the SVG images found
/// relative to the Markdown file's folder. The title is the first `# ` heading.
///
/// # Errors
/// Reading the Markdown file or writing the page.
pub fn convert_file(md_path: &Path, html_path: &Path) -> std::io::Result<()> {
    let md = std::fs::read_to_string(md_path)?;
    let dir = md_path.parent().unwrap_or(Path::new("."));
    write_page(&md, dir, html_path)
}

/// Writes `md` as the page `html_path`, inlining the SVG images it links from `dir`
/// (plain relative names only), opened by the one screen of summary and the table of
/// contents of [`crate::summary::with_summary`] (read from the files in `dir`). The
/// title is the first `# ` heading.
///
/// # Errors
/// Writing the page.
pub fn write_page(md: &str, dir: &Path, html_path: &Path) -> std::io::Result<()> {
    let md = crate::summary::with_summary(md, dir, &crate::articulated_report::root());
    let md = md.as_str();
    let title = md
        .lines()
        .find_map(|l| l.strip_prefix("# "))
        .unwrap_or("Verification report")
        .trim()
        .to_string();
    let load = |src: &str| -> Option<String> {
        // Only plain relative names: the report links files beside itself.
        if src.contains("..") || src.starts_with('/') || src.contains(':') {
            return None;
        }
        std::fs::read_to_string(dir.join(src)).ok()
    };
    std::fs::write(html_path, to_html(md, &title, &load))
}

/// A heading of a Markdown text: its level, text and the unique id the page gives it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Heading {
    /// Level, 1 for `#`.
    pub level: usize,
    /// The heading's text (Markdown).
    pub text: String,
    /// Its id: the lowercase slug of the text, with `-2`, `-3` … appended to repeats.
    pub id: String,
}

/// The headings of `md` in order, outside fenced code, with unique ids.
pub fn headings(md: &str) -> Vec<Heading> {
    let mut out: Vec<Heading> = Vec::new();
    let mut fenced = false;
    for line in md.lines() {
        let t = line.trim();
        if t.starts_with("```") {
            fenced = !fenced;
            continue;
        }
        if fenced {
            continue;
        }
        if let Some((level, text)) = heading(t) {
            let base = slug(text);
            let mut id = base.clone();
            let mut k = 1;
            while out.iter().any(|h| h.id == id) {
                k += 1;
                id = format!("{base}-{k}");
            }
            out.push(Heading {
                level,
                text: text.to_string(),
                id,
            });
        }
    }
    out
}

fn heading(t: &str) -> Option<(usize, &str)> {
    let level = t.chars().take_while(|c| *c == '#').count();
    if (1..=6).contains(&level) && t[level..].starts_with(' ') {
        Some((level, t[level..].trim()))
    } else {
        None
    }
}

/// A lowercase id of letters, digits and dashes.
fn slug(text: &str) -> String {
    let mut s = String::new();
    for c in text.chars() {
        if c.is_ascii_alphanumeric() {
            s.push(c.to_ascii_lowercase());
        } else if !s.ends_with('-') && !s.is_empty() {
            s.push('-');
        }
    }
    s.trim_end_matches('-').to_string()
}

/// `![alt](src)` alone on a line.
fn lone_image(t: &str) -> Option<(&str, &str)> {
    let rest = t.strip_prefix("![")?;
    let close = rest.find("](")?;
    let alt = &rest[..close];
    let src = rest[close + 2..].strip_suffix(')')?;
    if src.contains(')') || src.contains(' ') {
        return None;
    }
    Some((alt, src))
}

fn figure(alt: &str, src: &str, load_svg: &dyn Fn(&str) -> Option<String>, body: &mut String) {
    if src.ends_with(".html") {
        frame(alt, src, load_svg(src), body);
        return;
    }
    if !src.ends_with(".svg") {
        let _ = writeln!(
            body,
            r#"<p class="missing">image not embedded (not an SVG): {}</p>"#,
            escape(src)
        );
        return;
    }
    match load_svg(src) {
        Some(svg) => {
            let svg = strip_prolog(&svg);
            let _ = writeln!(
                body,
                "<figure>\n{}\n<figcaption>{} ({})</figcaption>\n</figure>",
                svg.trim_end(),
                escape(alt),
                escape(src)
            );
        }
        None => {
            let _ = writeln!(
                body,
                r#"<p class="missing">missing chart: {} ({})</p>"#,
                escape(alt),
                escape(src)
            );
        }
    }
}

/// A linked page embedded whole: `srcdoc` holds it (escaped), `sandbox="allow-scripts"`
/// lets its script run without access to the report.
fn frame(alt: &str, src: &str, page: Option<String>, body: &mut String) {
    match page {
        Some(page) => {
            let _ = writeln!(
                body,
                "<figure>\n<iframe title=\"{}\" sandbox=\"allow-scripts\" \
                 style=\"width:100%;height:520px;border:1px solid #bbb\" srcdoc=\"{}\"></iframe>\n\
                 <figcaption>{} ({})</figcaption>\n</figure>",
                escape(alt),
                escape(&page),
                escape(alt),
                escape(src)
            );
        }
        None => {
            let _ = writeln!(
                body,
                r#"<p class="missing">missing page: {} ({})</p>"#,
                escape(alt),
                escape(src)
            );
        }
    }
}

/// Drops an XML declaration and doctype before the `<svg` element.
fn strip_prolog(svg: &str) -> &str {
    svg.find("<svg").map_or(svg, |k| &svg[k..])
}

/// Splits a table row on unescaped pipes (`\|` is a literal pipe).
fn cells(row: &str) -> Vec<String> {
    let t = row.trim();
    let t = t.strip_prefix('|').unwrap_or(t);
    let t = t
        .strip_suffix('|')
        .filter(|_| !t.ends_with("\\|"))
        .unwrap_or(t);
    let mut out = Vec::new();
    let mut cur = String::new();
    let mut chars = t.chars().peekable();
    while let Some(c) = chars.next() {
        if c == '\\' && chars.peek() == Some(&'|') {
            cur.push('|');
            chars.next();
        } else if c == '|' {
            out.push(cur.trim().to_string());
            cur.clear();
        } else {
            cur.push(c);
        }
    }
    out.push(cur.trim().to_string());
    out
}

fn is_separator(row: &str) -> bool {
    let c = cells(row);
    !c.is_empty()
        && c.iter().all(|x| {
            let x = x.trim();
            !x.is_empty() && x.chars().all(|ch| matches!(ch, '-' | ':'))
        })
}

fn table(rows: &[&str], body: &mut String) {
    let (head, rest) = if rows.len() >= 2 && is_separator(rows[1]) {
        (Some(cells(rows[0])), &rows[2..])
    } else {
        (None, rows)
    };
    let width = head.as_ref().map(Vec::len);
    body.push_str("<table>\n");
    if let Some(h) = &head {
        body.push_str("<thead><tr>");
        for c in h {
            let _ = write!(body, "<th>{}</th>", inline(c));
        }
        body.push_str("</tr></thead>\n");
    }
    body.push_str("<tbody>\n");
    for r in rest {
        let mut c = cells(r);
        if let Some(w) = width {
            // As GitHub does: extra cells dropped, missing ones empty.
            c.resize(w, String::new());
        }
        body.push_str("<tr>");
        for x in &c {
            let _ = write!(body, "<td>{}</td>", inline(x));
        }
        body.push_str("</tr>\n");
    }
    body.push_str("</tbody>\n</table>\n");
}

/// Inline Markdown: `code`, **bold**, *emphasis* / _emphasis_ (not inside words for
/// `_`), `[links](url)`, images (alt text only: charts are block-level), backslash
/// escapes; everything else escaped.
pub fn inline(s: &str) -> String {
    let c: Vec<char> = s.chars().collect();
    let mut o = String::new();
    let mut i = 0;
    let find = |from: usize, pat: &[char]| -> Option<usize> {
        (from..c.len().saturating_sub(pat.len() - 1)).find(|&k| c[k..k + pat.len()] == *pat)
    };
    while i < c.len() {
        let ch = c[i];
        if ch == '\\' && i + 1 < c.len() && "\\`*_[]()#|!<>-".contains(c[i + 1]) {
            o.push_str(&escape(&c[i + 1].to_string()));
            i += 2;
        } else if ch == '`' {
            if let Some(end) = find(i + 1, &['`']) {
                let code: String = c[i + 1..end].iter().collect();
                let _ = write!(o, "<code>{}</code>", escape(&code));
                i = end + 1;
            } else {
                o.push('`');
                i += 1;
            }
        } else if ch == '*' && c.get(i + 1) == Some(&'*') {
            match find(i + 2, &['*', '*']) {
                Some(end) if end > i + 2 => {
                    let inner: String = c[i + 2..end].iter().collect();
                    let _ = write!(o, "<strong>{}</strong>", inline(&inner));
                    i = end + 2;
                }
                _ => {
                    o.push_str("**");
                    i += 2;
                }
            }
        } else if (ch == '*' || ch == '_')
            && c.get(i + 1).is_some_and(|n| !n.is_whitespace())
            && (ch == '*' || i == 0 || !c[i - 1].is_alphanumeric())
        {
            let end = (i + 1..c.len()).find(|&k| {
                c[k] == ch
                    && !c[k - 1].is_whitespace()
                    && (ch == '*' || c.get(k + 1).is_none_or(|n| !n.is_alphanumeric()))
            });
            match end {
                Some(end) => {
                    let inner: String = c[i + 1..end].iter().collect();
                    let _ = write!(o, "<em>{}</em>", inline(&inner));
                    i = end + 1;
                }
                None => {
                    o.push(ch);
                    i += 1;
                }
            }
        } else if ch == '[' || (ch == '!' && c.get(i + 1) == Some(&'[')) {
            let img = ch == '!';
            let open = if img { i + 1 } else { i };
            let link = find(open + 1, &[']', '(']).and_then(|m| {
                let close = find(m + 2, &[')'])?;
                Some((m, close))
            });
            match link {
                Some((m, close)) => {
                    let text: String = c[open + 1..m].iter().collect();
                    let url: String = c[m + 2..close].iter().collect();
                    if img {
                        let _ = write!(o, "[{}]", escape(&text));
                    } else {
                        let _ = write!(o, r#"<a href="{}">{}</a>"#, escape(&url), inline(&text));
                    }
                    i = close + 1;
                }
                None => {
                    o.push_str(&escape(&ch.to_string()));
                    i += 1;
                }
            }
        } else {
            o.push_str(&escape(&ch.to_string()));
            i += 1;
        }
    }
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    fn none(_: &str) -> Option<String> {
        None
    }

    #[test]
    fn headings_paragraphs_and_inline_markup() {
        let h = to_html(
            "# Report\n\nSome `a<b` text,\n**bold** and *em* and snake_case_name.\n\n## Part two\n",
            "T",
            &none,
        );
        assert!(h.contains(r#"<h1 id="report">Report</h1>"#));
        assert!(h.contains(r#"<h2 id="part-two">Part two</h2>"#));
        assert!(h.contains(
            "<p>Some <code>a&lt;b</code> text,\n<strong>bold</strong> and <em>em</em> and snake_case_name.</p>"
        ));
        assert!(h.starts_with("<!DOCTYPE html>") && h.ends_with("</html>\n"));
        assert!(h.contains("<title>T</title>"));
    }

    #[test]
    fn tables_with_header_escaped_pipes_and_ragged_rows() {
        let h = to_html(
            "| a | max \\|C\\| |\n|---|---|\n| 1 | 2 |\n| 3 |\n| 4 | 5 | 6 |\n",
            "T",
            &none,
        );
        assert!(h.contains("<thead><tr><th>a</th><th>max |C|</th></tr></thead>"));
        assert!(h.contains("<tr><td>1</td><td>2</td></tr>"));
        assert!(h.contains("<tr><td>3</td><td></td></tr>"));
        assert!(h.contains("<tr><td>4</td><td>5</td></tr>"));
    }

    #[test]
    fn fenced_code_is_escaped_verbatim() {
        let h = to_html(
            "```sh\ncargo <x> && y\n  indented\n```\nafter\n",
            "T",
            &none,
        );
        assert!(h.contains(
            "<pre><code class=\"language-sh\">cargo &lt;x&gt; &amp;&amp; y\n  indented\n</code></pre>"
        ));
        assert!(h.contains("<p>after</p>"));
    }

    #[test]
    fn svg_images_are_inlined_and_missing_ones_reported() {
        let load = |p: &str| {
            (p == "a.svg").then(|| "<?xml version=\"1.0\"?>\n<svg id=\"x\"></svg>\n".to_string())
        };
        let h = to_html("![chart a](a.svg)\n\n![chart b](b.svg)\n", "T", &load);
        assert!(
            h.contains("<figure>\n<svg id=\"x\"></svg>\n<figcaption>chart a (a.svg)</figcaption>")
        );
        assert!(!h.contains("<?xml"));
        assert!(h.contains(r#"<p class="missing">missing chart: chart b (b.svg)</p>"#));
        assert!(!h.contains("<img"));
    }

    #[test]
    fn html_pages_are_embedded_escaped_in_a_sandboxed_frame() {
        let load = |p: &str| (p == "r.html").then(|| "<p class=\"x\">a & b</p>".to_string());
        let h = to_html("![replay r](r.html)\n\n![replay s](s.html)\n", "T", &load);
        // The page travels whole inside one attribute: every quote, angle bracket and
        // ampersand escaped, so it cannot close the frame element.
        assert!(h.contains(
            r#"sandbox="allow-scripts" style="width:100%;height:520px;border:1px solid #bbb" srcdoc="&lt;p class=&quot;x&quot;&gt;a &amp; b&lt;/p&gt;"></iframe>"#
        ));
        assert!(h.contains("<figcaption>replay r (r.html)</figcaption>"));
        assert!(h.contains(r#"<p class="missing">missing page: replay s (s.html)</p>"#));
    }

    #[test]
    fn lists_and_links() {
        let h = to_html(
            "* one [site](http://a?b&c)\n  continued\n- two\n\ntext\n",
            "T",
            &none,
        );
        assert!(h.contains(
            "<ul>\n<li>one <a href=\"http://a?b&amp;c\">site</a> continued</li>\n<li>two</li>\n</ul>"
        ));
        assert!(h.contains("<p>text</p>"));
    }

    #[test]
    fn unbalanced_markup_is_left_as_text() {
        assert_eq!(inline("a * b ` c [d"), "a * b ` c [d");
        assert_eq!(inline("2*3 = 6"), "2*3 = 6");
        assert_eq!(inline("x < y & z"), "x &lt; y &amp; z");
    }

    #[test]
    fn repeated_headings_get_unique_ids() {
        let md = "## Summary\n\n```\n## not a heading\n```\n\n### Summary\n\n## Summary\n";
        let ids: Vec<String> = headings(md).into_iter().map(|h| h.id).collect();
        assert_eq!(ids, ["summary", "summary-2", "summary-3"]);
        let h = to_html(md, "T", &none);
        assert!(h.contains(r#"<h3 id="summary-2">Summary</h3>"#));
        assert!(h.contains(r#"<h2 id="summary-3">Summary</h2>"#));
    }

    #[test]
    fn a_table_after_a_chart_folds_until_the_next_heading() {
        let md = "## A\n\n![c](c.svg)\n\nnote\n\n| a |\n|---|\n| 1 |\n| 2 |\n\n## B\n\n| b |\n|---|\n| 3 |\n";
        let h = to_html(md, "T", &none);
        assert!(
            h.contains("<details>\n<summary>Table: the chart's data, 2 row(s)</summary>\n<table>")
        );
        assert_eq!(h.matches("<details>").count(), 1);
        assert!(h.contains("</table>\n</details>\n<h2 id=\"b\">B</h2>"));
    }

    #[test]
    fn conversion_is_deterministic() {
        let md = "# R\n\n| a | b |\n|---|---|\n| 1 | 2 |\n";
        assert_eq!(to_html(md, "R", &none), to_html(md, "R", &none));
    }
}
