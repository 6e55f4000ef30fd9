//! CSV text through the `csv` crate, the one writer and reader of every CSV file the tool
//! writes or reads (reports, `log.csv`, `eval_log.csv`, `validate`, the faithfulness steps):
//! a field holding a comma, a quote or a newline — a checkpoint path, say — is quoted, so
//! columns never shift. Numbers are formatted by the callers, so the bytes of ordinary rows
//! are what they always were. A file with a row type of its own (`episodes.csv`) writes and
//! reads it through serde ([`Table::serialize`], [`deserialize`]).

use std::fmt::Display;

use serde::Serialize;
use serde::de::DeserializeOwned;

use crate::stats::MeanStd;

/// One record, built field by field.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Record(Vec<String>);

impl Record {
    /// An empty record.
    pub fn new() -> Self {
        Self::default()
    }

    /// Appends one field.
    #[must_use]
    pub fn field(mut self, x: impl Display) -> Self {
        self.0.push(x.to_string());
        self
    }

    /// Appends `mean` and `std` with six decimals, or two empty fields when nothing was
    /// measured.
    #[must_use]
    pub fn mean_std(self, m: &MeanStd) -> Self {
        match (m.mean, m.std) {
            (Some(a), Some(b)) => self.field(format!("{a:.6}")).field(format!("{b:.6}")),
            _ => self.field("").field(""),
        }
    }

    /// Appends the fields of `other`.
    #[must_use]
    pub fn extend(mut self, other: Self) -> Self {
        self.0.extend(other.0);
        self
    }
}

/// A CSV text being written: a header line, then records.
#[derive(Debug)]
pub struct Table {
    w: csv::Writer<Vec<u8>>,
}

impl Table {
    /// A table whose header is `columns` (comma-separated names).
    pub fn new(columns: &str) -> Self {
        let mut t = Self {
            // The header is `columns`, written here: a serialized row never writes its own.
            w: csv::WriterBuilder::new()
                .has_headers(false)
                .flexible(true)
                .terminator(csv::Terminator::Any(b'\n'))
                .from_writer(Vec::new()),
        };
        t.push(&columns.split(',').fold(Record::new(), Record::field));
        t
    }

    /// Appends one record.
    pub fn push(&mut self, r: &Record) {
        // Writing to a Vec cannot fail.
        let _ = self.w.write_record(&r.0);
    }

    /// Appends one record serialized from `row`, a struct whose fields are the columns in the
    /// header's order (strings and integers as they display, `None` as an empty field).
    pub fn serialize(&mut self, row: &impl Serialize) {
        // Writing plain fields to a Vec cannot fail.
        let _ = self.w.serialize(row);
    }

    /// The text.
    pub fn finish(self) -> String {
        let bytes = self.w.into_inner().unwrap_or_default();
        String::from_utf8(bytes).unwrap_or_default()
    }
}

/// One record as a line of text with its newline (for files appended to a line at a time,
/// such as `log.csv`).
pub fn line(r: &Record) -> String {
    let mut w = csv::WriterBuilder::new()
        .terminator(csv::Terminator::Any(b'\n'))
        .from_writer(Vec::new());
    let _ = w.write_record(&r.0);
    String::from_utf8(w.into_inner().unwrap_or_default()).unwrap_or_default()
}

/// Reads CSV `text` with a header: the header's names and the records, every record as long
/// as the header; `Err` names the line of the first malformed record.
pub fn read(text: &str) -> Result<(Vec<String>, Vec<Vec<String>>), String> {
    let mut r = csv::ReaderBuilder::new()
        .has_headers(true)
        .from_reader(text.as_bytes());
    let header: Vec<String> = r
        .headers()
        .map_err(|e| e.to_string())?
        .iter()
        .map(str::to_owned)
        .collect();
    let mut rows = Vec::new();
    for (i, rec) in r.records().enumerate() {
        let rec = rec.map_err(|e| format!("line {}: {e}", i + 2))?;
        rows.push(rec.iter().map(str::to_owned).collect());
    }
    Ok((header, rows))
}

/// Why one record did not read as its row type ([`deserialize`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FieldError {
    /// The column at fault, where the CSV reader knows it (it does when a field does not
    /// parse as its type; a row type's own message names no column).
    pub column: Option<String>,
    /// That column's text in the record.
    pub value: Option<String>,
    /// Whether the text failed to parse as the column's type (a number, say), rather than
    /// being refused by the row type itself.
    pub unparsed: bool,
    /// What went wrong, as the reader or the row type says it.
    pub reason: String,
}

/// Reads one record, `cells` under `header` (as [`read`] gives them), as a `T` whose fields
/// are named by the columns; columns `T` does not name are skipped.
pub fn deserialize<T: DeserializeOwned>(
    header: &[String],
    cells: &[String],
) -> Result<T, FieldError> {
    let header = csv::StringRecord::from(header);
    let record = csv::StringRecord::from(cells);
    record
        .deserialize::<T>(Some(&header))
        .map_err(|e| match e.kind() {
            csv::ErrorKind::Deserialize { err, .. } => {
                let at = err.field().and_then(|f| usize::try_from(f).ok());
                FieldError {
                    column: at.and_then(|i| header.get(i)).map(str::to_owned),
                    value: at.and_then(|i| record.get(i)).map(str::to_owned),
                    unparsed: matches!(
                        err.kind(),
                        csv::DeserializeErrorKind::ParseBool(_)
                            | csv::DeserializeErrorKind::ParseInt(_)
                            | csv::DeserializeErrorKind::ParseFloat(_)
                    ),
                    reason: err.kind().to_string(),
                }
            }
            _ => FieldError {
                column: None,
                value: None,
                unparsed: false,
                reason: e.to_string(),
            },
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_are_quoted_only_where_needed_and_read_back() {
        let mut t = Table::new("checkpoint,size,acc_mean,acc_std");
        let m = MeanStd {
            mean: Some(0.5),
            std: Some(0.25),
        };
        t.push(&Record::new().field("runs/a").field(8).mean_std(&m));
        t.push(
            &Record::new()
                .field("runs/a,b \"x\"")
                .field(16)
                .mean_std(&MeanStd::of(&[])),
        );
        let text = t.finish();
        assert_eq!(
            text,
            "checkpoint,size,acc_mean,acc_std\nruns/a,8,0.500000,0.250000\n\"runs/a,b \"\"x\"\"\",16,,\n"
        );
        let (header, rows) = read(&text).unwrap();
        assert_eq!(header, ["checkpoint", "size", "acc_mean", "acc_std"]);
        assert_eq!(rows[1], ["runs/a,b \"x\"", "16", "", ""]);
        assert_eq!(line(&Record::new().field(1).field("a,b")), "1,\"a,b\"\n");
        let err = read("a,b\n1,2\n3\n").unwrap_err();
        assert!(err.starts_with("line 3"), "{err}");
    }
}
