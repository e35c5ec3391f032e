//! The table model: rows of typed cells under columns defined once. A
//! column says how it is headed in the display formats (text, Markdown,
//! HTML), how it is keyed in the data formats (CSV, JSON) and how its
//! values are shown; a cell says only what the value is. Every renderer in
//! this module's siblings reads the same table, so a row is built once.
//!
//! A table is built from typed rows ([`Table::of`]): each column is a
//! [`Field`], its header defined with the accessor that reads its cell from
//! a row, so a value cannot be put under another column's header. Cells
//! pushed by position exist only for the renderers' own tests.

use crate::stats::Interval;
use serde::ser::{Serialize, SerializeMap, SerializeStruct, Serializer};

/// The mark after an incomplete model's name, in every table and figure.
pub(crate) const INCOMPLETE_MARK: &str = "\u{2020}";

/// One value of a table.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Cell {
    Text(String),
    /// A model name with a mark: "name †" on display, the name alone in
    /// the data formats (an incomplete model).
    Marked(String),
    Int(u64),
    Float(f64),
    /// An estimate with its 95% interval; three CSV columns (`key`,
    /// `key_lo`, `key_hi`). An estimate without bounds has NaN bounds.
    Interval(Interval),
    /// A percentage, shown with one decimal and a `%` sign.
    Percent(f64),
    /// A value followed by a second one in parentheses: "12 (3.4%)".
    WithParen(Box<Cell>, Box<Cell>),
    /// No value: "-" on display, empty in CSV, `null` in JSON.
    Missing,
    /// Not known: "?" on display, empty in CSV, `null` in JSON.
    Unknown,
    /// Nothing to show: empty everywhere, `null` in JSON.
    Blank,
}

impl Cell {
    pub(crate) fn text(s: impl Into<String>) -> Cell {
        Cell::Text(s.into())
    }

    /// `Some(x)` as a float, `None` as [`Cell::Missing`].
    pub(crate) fn opt(x: Option<f64>) -> Cell {
        x.map_or(Cell::Missing, Cell::Float)
    }

    /// An estimate without bounds (a reference level in an interval column).
    pub(crate) fn estimate(x: f64) -> Cell {
        Cell::Interval(Interval { estimate: x, lo: f64::NAN, hi: f64::NAN })
    }

    /// A number (or nothing): right-aligned in HTML.
    pub(crate) fn is_numeric_or_empty(&self) -> bool {
        match self {
            Cell::Text(_) | Cell::Marked(_) => false,
            Cell::WithParen(a, _) => a.is_numeric_or_empty(),
            _ => true,
        }
    }

    /// The value as shown in the text, Markdown and HTML renderings.
    pub(crate) fn display(&self, style: Style) -> String {
        match (self, style) {
            (Cell::Text(s), _) => s.clone(),
            (Cell::Marked(s), _) => format!("{s} {INCOMPLETE_MARK}"),
            (Cell::Int(n), _) => n.to_string(),
            (Cell::Float(x), Style::Signed) => format!("{x:+.2}"),
            (Cell::Float(x), Style::Whole) => {
                if x.is_finite() {
                    format!("{x:.0}")
                } else {
                    "-".into()
                }
            }
            (Cell::Float(x), Style::PValue) => p_value(*x),
            (Cell::Float(x), _) => f2(*x),
            (Cell::Interval(i), Style::SignedInterval) if i.lo.is_finite() => {
                format!("{:+.2} [{:+.2}, {:+.2}]", i.estimate, i.lo, i.hi)
            }
            (Cell::Interval(i), _) => with_ci(i),
            (Cell::Percent(x), _) => format!("{x:.1}%"),
            (Cell::WithParen(a, b), _) => format!("{} ({})", a.display(style), b.display(style)),
            (Cell::Missing, _) => "-".into(),
            (Cell::Unknown, _) => "?".into(),
            (Cell::Blank, _) => String::new(),
        }
    }

    /// The CSV fields of the value: three for an interval column, else one.
    pub(crate) fn csv_fields(&self, style: Style) -> Vec<String> {
        let interval = |i: &Interval| vec![f4(i.estimate), f4(i.lo), f4(i.hi)];
        match (self, style) {
            (Cell::Interval(i), _) => interval(i),
            (Cell::Missing | Cell::Unknown | Cell::Blank, _) if style.is_interval() => vec![String::new(); 3],
            (Cell::Float(x), Style::PValue) if x.is_finite() => vec![format!("{x:.6e}")],
            (Cell::Float(x) | Cell::Percent(x), _) => vec![f4(*x)],
            (Cell::Text(s) | Cell::Marked(s), _) => vec![s.clone()],
            (Cell::Int(n), _) => vec![n.to_string()],
            (Cell::WithParen(a, _), _) => a.csv_fields(style),
            (Cell::Missing | Cell::Unknown | Cell::Blank, _) => vec![String::new()],
        }
    }
}

/// Finite numbers as JSON numbers, anything undefined as `null`.
impl Serialize for Cell {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let number = |x: f64| x.is_finite().then_some(x);
        match self {
            Cell::Text(t) | Cell::Marked(t) => s.serialize_str(t),
            Cell::Int(n) => s.serialize_u64(*n),
            Cell::Float(x) | Cell::Percent(x) => number(*x).serialize(s),
            Cell::Interval(i) => {
                let mut st = s.serialize_struct("Interval", 3)?;
                st.serialize_field("estimate", &number(i.estimate))?;
                st.serialize_field("lo", &number(i.lo))?;
                st.serialize_field("hi", &number(i.hi))?;
                st.end()
            }
            Cell::WithParen(a, b) => [a, b].serialize(s),
            Cell::Missing | Cell::Unknown | Cell::Blank => s.serialize_none(),
        }
    }
}

/// How a column shows its values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) enum Style {
    /// Text as is, numbers with two decimals, intervals "0.53 [0.46, 0.60]".
    #[default]
    Plain,
    /// An identifier: as [`Style::Plain`], in backticks in Markdown.
    Code,
    /// An interval column: three CSV fields (`key`, `key_lo`, `key_hi`),
    /// empty cells included.
    Interval,
    /// An interval column of signed differences: "+0.12 [-0.03, +0.25]".
    SignedInterval,
    /// Numbers with a sign: "+0.12".
    Signed,
    /// Numbers rounded to a whole: "1234".
    Whole,
    /// A p-value: "<0.001" or three decimals; CSV in scientific notation.
    PValue,
}

impl Style {
    fn is_interval(self) -> bool {
        matches!(self, Style::Interval | Style::SignedInterval)
    }
}

/// One column, defined once for every format.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Column {
    /// Header in the display formats; `None`: a data-only column.
    pub(crate) header: Option<String>,
    /// CSV header and JSON key; `None`: a display-only column.
    pub(crate) key: Option<String>,
    pub(crate) style: Style,
}

impl Column {
    /// A column shown everywhere: `header` on display, `key` in CSV and JSON.
    pub(crate) fn new(header: impl Into<String>, key: impl Into<String>) -> Column {
        Column { header: Some(header.into()), key: Some(key.into()), style: Style::Plain }
    }

    /// A column of the display formats only.
    pub(crate) fn display(header: impl Into<String>) -> Column {
        Column { header: Some(header.into()), key: None, style: Style::Plain }
    }

    /// A column of the data formats (CSV, JSON) only.
    pub(crate) fn data(key: impl Into<String>) -> Column {
        Column { header: None, key: Some(key.into()), style: Style::Plain }
    }

    pub(crate) fn style(mut self, style: Style) -> Column {
        self.style = style;
        self
    }

    /// The CSV header fields: `key`, plus `key_lo`, `key_hi` for intervals.
    pub(crate) fn csv_headers(&self) -> Vec<String> {
        match &self.key {
            None => Vec::new(),
            Some(k) if self.style.is_interval() => vec![k.clone(), format!("{k}_lo"), format!("{k}_hi")],
            Some(k) => vec![k.clone()],
        }
    }
}

/// A column of a table whose rows are `R`s: the [`Column`] and the accessor
/// that reads its cell from a row. A header and its value are defined
/// together, so a value cannot land under another column: reordering the
/// fields reorders both.
pub(crate) struct Field<'a, R: ?Sized> {
    column: Column,
    cell: Box<dyn Fn(&R) -> Cell + 'a>,
}

impl<'a, R: ?Sized + 'a> Field<'a, R> {
    pub(crate) fn new(column: Column, cell: impl Fn(&R) -> Cell + 'a) -> Field<'a, R> {
        Field { column, cell: Box::new(cell) }
    }

    /// A column of numbers, each read by `value`.
    pub(crate) fn float(column: Column, value: impl Fn(&R) -> f64 + 'a) -> Field<'a, R> {
        Field::new(column, move |row| Cell::Float(value(row)))
    }

    /// A column of counts, each read by `value`.
    pub(crate) fn int(column: Column, value: impl Fn(&R) -> u64 + 'a) -> Field<'a, R> {
        Field::new(column, move |row| Cell::Int(value(row)))
    }

    /// A column of estimates with their intervals, each read by `value`.
    pub(crate) fn interval(column: Column, value: impl Fn(&R) -> Interval + 'a) -> Field<'a, R> {
        Field::new(column, move |row| Cell::Interval(value(row)))
    }

    /// The same column read from the part `part` picks of a larger row (the
    /// metrics of a summary's cell, the belief of a baseline's).
    pub(crate) fn of<S: ?Sized + 'a>(self, part: impl Fn(&S) -> &R + 'a) -> Field<'a, S> {
        let cell = self.cell;
        Field { column: self.column, cell: Box::new(move |row| cell(part(row))) }
    }
}

/// A table: a name (the CSV file stem), a title, columns, rows and notes.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct Table {
    pub(crate) name: String,
    /// Shown above the table; empty: none.
    pub(crate) title: String,
    pub(crate) columns: Vec<Column>,
    pub(crate) rows: Vec<Vec<Cell>>,
    /// Lines shown under the table (display formats only).
    pub(crate) notes: Vec<String>,
}

impl Table {
    pub(crate) fn new(name: &str, title: impl Into<String>, columns: Vec<Column>) -> Table {
        Table { name: name.to_string(), title: title.into(), columns, ..Table::default() }
    }

    /// A table of `rows`, each cell read by its column's field: the way
    /// every table of the program is built.
    pub(crate) fn of<'r, R: ?Sized + 'r>(
        name: &str,
        title: impl Into<String>,
        fields: &[Field<'_, R>],
        rows: impl IntoIterator<Item = &'r R>,
    ) -> Table {
        let mut t = Table::new(name, title, fields.iter().map(|f| f.column.clone()).collect());
        t.rows = rows.into_iter().map(|row| fields.iter().map(|f| (f.cell)(row)).collect()).collect();
        t
    }

    /// Add a row: one cell per column (the renderers' tests build tables
    /// cell by cell; the program builds them from fields, [`Table::of`]).
    #[cfg(test)]
    pub(crate) fn push(&mut self, row: Vec<Cell>) {
        assert_eq!(row.len(), self.columns.len(), "table {}: a row needs one cell per column", self.name);
        self.rows.push(row);
    }

    pub(crate) fn note(&mut self, note: impl Into<String>) {
        self.notes.push(note.into());
    }

    /// The display columns' indices.
    pub(crate) fn shown(&self) -> impl Iterator<Item = (usize, &str)> {
        self.columns.iter().enumerate().filter_map(|(i, c)| c.header.as_deref().map(|h| (i, h)))
    }

    /// Rows as displayed: one string per display column.
    pub(crate) fn display_rows(&self) -> Vec<Vec<String>> {
        let shown: Vec<usize> = self.shown().map(|(i, _)| i).collect();
        self.rows.iter().map(|r| shown.iter().map(|&i| r[i].display(self.columns[i].style)).collect()).collect()
    }

    /// Rows of one data format: `(key, cell)` per data column.
    pub(crate) fn data_rows(&self) -> impl Iterator<Item = DataRow<'_>> {
        self.rows.iter().map(|cells| DataRow { columns: &self.columns, cells })
    }
}

/// One row of the data formats: its data columns, keyed.
pub(crate) struct DataRow<'a> {
    columns: &'a [Column],
    cells: &'a [Cell],
}

impl<'a> DataRow<'a> {
    pub(crate) fn fields(&self) -> impl Iterator<Item = (&'a Column, &'a Cell)> + use<'a> {
        self.columns.iter().zip(self.cells).filter(|(c, _)| c.key.is_some())
    }
}

/// A JSON object with the data columns' keys, in column order.
impl Serialize for DataRow<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut map = s.serialize_map(None)?;
        for (column, cell) in self.fields() {
            map.serialize_entry(column.key.as_deref().unwrap_or_default(), cell)?;
        }
        map.end()
    }
}

/// Two decimals, or "-" when undefined.
pub(crate) fn f2(x: f64) -> String {
    if x.is_finite() { format!("{x:.2}") } else { "-".to_string() }
}

/// Four decimals for CSV, or empty when undefined.
pub(crate) fn f4(x: f64) -> String {
    if x.is_finite() { format!("{x:.4}") } else { String::new() }
}

/// "0.53 [0.46, 0.60]"; the estimate alone when the bounds are undefined.
pub(crate) fn with_ci(i: &Interval) -> String {
    if i.lo.is_finite() && i.hi.is_finite() {
        format!("{} [{}, {}]", f2(i.estimate), f2(i.lo), f2(i.hi))
    } else {
        f2(i.estimate)
    }
}

pub(crate) fn p_value(p: f64) -> String {
    if !p.is_finite() {
        "-".into()
    } else if p < 0.001 {
        "<0.001".into()
    } else {
        format!("{p:.3}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Row {
        name: &'static str,
        wins: u64,
        share: f64,
    }

    fn fields() -> Vec<Field<'static, Row>> {
        vec![
            Field::new(Column::new("name", "name"), |r: &Row| Cell::text(r.name)),
            Field::new(Column::new("wins", "wins"), |r: &Row| Cell::Int(r.wins)),
            Field::new(Column::new("share", "share"), |r: &Row| Cell::Float(r.share)),
        ]
    }

    /// A value is read by its own column's accessor: whatever order the
    /// fields are listed in, each key carries its own value.
    #[test]
    fn a_value_stays_under_its_column_whatever_the_order() {
        let rows = [Row { name: "a", wins: 3, share: 0.25 }, Row { name: "b", wins: 1, share: 0.5 }];
        let straight = Table::of("t", "", &fields(), &rows);
        let mut reversed_fields = fields();
        reversed_fields.reverse();
        let reversed = Table::of("t", "", &reversed_fields, &rows);
        let keyed = |t: &Table| -> Vec<Vec<(String, Cell)>> {
            let mut rows: Vec<Vec<(String, Cell)>> = t
                .data_rows()
                .map(|r| r.fields().map(|(c, cell)| (c.key.clone().unwrap(), cell.clone())).collect())
                .collect();
            rows.iter_mut().for_each(|r| r.sort_by(|a, b| a.0.cmp(&b.0)));
            rows
        };
        assert_eq!(keyed(&straight), keyed(&reversed));
        assert_eq!(straight.rows[0], [Cell::text("a"), Cell::Int(3), Cell::Float(0.25)]);
        assert_eq!(reversed.columns[0].key.as_deref(), Some("share"));
    }

    /// A part's fields read through `of` show the part of each row.
    #[test]
    fn fields_of_a_part_read_that_part() {
        struct Outer {
            label: &'static str,
            inner: Row,
        }
        let mut fields: Vec<Field<Outer>> =
            vec![Field::new(Column::new("label", "label"), |o: &Outer| Cell::text(o.label))];
        fields.extend(self::tests::fields().into_iter().map(|f| f.of(|o: &Outer| &o.inner)));
        let rows = [Outer { label: "x", inner: Row { name: "n", wins: 2, share: 1.0 } }];
        let t = Table::of("t", "", &fields, &rows);
        assert_eq!(t.rows[0], [Cell::text("x"), Cell::text("n"), Cell::Int(2), Cell::Float(1.0)]);
    }
}
