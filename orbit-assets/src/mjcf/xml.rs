//! A small element tree of an MJCF document, each element with its line, and the attribute
//! readers the importer uses. Every error names the element, the attribute and the line.

use std::collections::HashMap;

use crate::error::AssetError;

/// An XML element: name, attributes in file order, children, and its line (1-based).
#[derive(Clone, Debug)]
pub(crate) struct Element {
    pub name: String,
    pub attrs: Vec<(String, String)>,
    pub children: Vec<Element>,
    pub line: usize,
}

/// Parses `text` into its root element.
pub(crate) fn parse(text: &str, file: &str) -> Result<Element, AssetError> {
    use quick_xml::events::{BytesStart, Event};
    let mut reader = quick_xml::Reader::from_str(text);
    let line_at = |pos: u64| {
        1 + text.as_bytes()[..(pos as usize).min(text.len())]
            .iter()
            .filter(|&&b| b == b'\n')
            .count()
    };
    let open = |e: &BytesStart, line: usize, decoder| -> Result<Element, AssetError> {
        let name = String::from_utf8_lossy(e.name().as_ref()).into_owned();
        let mut attrs = Vec::new();
        for attr in e.attributes() {
            let attr = attr.map_err(|err| AssetError::MjcfSyntax {
                file: file.to_string(),
                line,
                message: format!("<{name}>: {err}"),
            })?;
            let value = attr
                .decode_and_unescape_value(decoder)
                .map_err(|err| mjcf_error(file, line, &name, None, err.to_string()))?;
            attrs.push((
                String::from_utf8_lossy(attr.key.as_ref()).into_owned(),
                value.into_owned(),
            ));
        }
        Ok(Element {
            name,
            attrs,
            children: Vec::new(),
            line,
        })
    };
    let mut stack: Vec<Element> = Vec::new();
    loop {
        let start = reader.buffer_position();
        let event = reader.read_event().map_err(|e| AssetError::MjcfSyntax {
            file: file.to_string(),
            line: line_at(reader.error_position()),
            message: e.to_string(),
        })?;
        let line = line_at(start);
        match event {
            Event::Start(e) => stack.push(open(&e, line, reader.decoder())?),
            Event::Empty(e) => {
                let element = open(&e, line, reader.decoder())?;
                match stack.last_mut() {
                    Some(parent) => parent.children.push(element),
                    None => return Ok(element),
                }
            }
            Event::End(_) => {
                let element = stack.pop().expect("quick-xml matches end tags");
                match stack.last_mut() {
                    Some(parent) => parent.children.push(element),
                    None => return Ok(element),
                }
            }
            Event::Eof => {
                return Err(AssetError::MjcfSyntax {
                    file: file.to_string(),
                    line,
                    message: match stack.last() {
                        Some(open) => format!("`<{}>` is never closed", open.name),
                        None => "no root element; an MJCF file is one `<mujoco>` element".into(),
                    },
                });
            }
            _ => {}
        }
    }
}

/// An importer error at `line` of `file`, in `<element>` (and its `attribute`).
pub(crate) fn mjcf_error(
    file: &str,
    line: usize,
    element: &str,
    attribute: Option<&str>,
    message: String,
) -> AssetError {
    AssetError::Mjcf {
        file: file.to_string(),
        line,
        element: element.to_string(),
        attribute: attribute.map(str::to_string),
        message,
    }
}

/// An element's attributes after its default class's, read as numbers and words.
pub(crate) struct Attrs<'a> {
    pub file: &'a str,
    pub element: &'a Element,
    pub values: HashMap<String, String>,
}

impl Attrs<'_> {
    /// An error about `attribute` of this element.
    pub fn error(&self, attribute: Option<&str>, message: String) -> AssetError {
        mjcf_error(
            self.file,
            self.element.line,
            &self.element.name,
            attribute,
            message,
        )
    }

    /// The raw value of `name`.
    pub fn text(&self, name: &str) -> Option<&str> {
        self.values.get(name).map(String::as_str)
    }

    /// `name` as exactly `N` numbers, if present.
    pub fn numbers<const N: usize>(&self, name: &str) -> Result<Option<[f64; N]>, AssetError> {
        let Some(raw) = self.text(name) else {
            return Ok(None);
        };
        let values = self.list(name, raw)?;
        let values: [f64; N] = values.try_into().map_err(|v: Vec<f64>| {
            self.error(
                Some(name),
                format!("`{raw}` has {} numbers; {N} are expected", v.len()),
            )
        })?;
        Ok(Some(values))
    }

    /// `name` as one to `max` numbers (MuJoCo's `size`, `gear`, `friction`), if present.
    pub fn up_to(&self, name: &str, max: usize) -> Result<Option<Vec<f64>>, AssetError> {
        let Some(raw) = self.text(name) else {
            return Ok(None);
        };
        let values = self.list(name, raw)?;
        if values.is_empty() || values.len() > max {
            return Err(self.error(
                Some(name),
                format!(
                    "`{raw}` has {} numbers; 1 to {max} are expected",
                    values.len()
                ),
            ));
        }
        Ok(Some(values))
    }

    /// `name` as one number, if present.
    pub fn number(&self, name: &str) -> Result<Option<f64>, AssetError> {
        Ok(self.numbers::<1>(name)?.map(|[v]| v))
    }

    /// `name` as `true`/`false` (MuJoCo's `auto` is `None`), if present.
    pub fn flag(&self, name: &str) -> Result<Option<bool>, AssetError> {
        match self.text(name) {
            None | Some("auto") => Ok(None),
            Some("true") => Ok(Some(true)),
            Some("false") => Ok(Some(false)),
            Some(other) => Err(self.error(
                Some(name),
                format!("`{other}` is not `true`, `false` or `auto`"),
            )),
        }
    }

    /// The range `range` (two numbers, lower first) if the element is limited: `flag` `true`,
    /// or `auto`/absent with a range given (MuJoCo's autolimits). A limited `what` without a
    /// range is an error.
    pub fn limited_range(
        &self,
        flag: &str,
        range: &str,
        what: &str,
    ) -> Result<Option<[f64; 2]>, AssetError> {
        match (self.flag(flag)?, self.numbers::<2>(range)?) {
            (Some(false), _) | (None, None) => Ok(None),
            (Some(true), None) => {
                Err(self.error(Some(range), format!("a limited {what} needs a `{range}`")))
            }
            (_, Some([lo, hi])) if lo > hi => Err(self.error(
                Some(range),
                format!("the lower end {lo} is above the upper end {hi}"),
            )),
            (_, Some(r)) => Ok(Some(r)),
        }
    }

    fn list(&self, name: &str, raw: &str) -> Result<Vec<f64>, AssetError> {
        raw.split_whitespace()
            .map(|word| match word.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                _ => Err(self.error(Some(name), format!("`{word}` is not a finite number"))),
            })
            .collect()
    }
}
