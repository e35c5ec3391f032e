//! The table system, modelled on hyperfine's `markup.rs`: a `Table` is
//! rows of typed `Cell`s under `Column`s defined once (display header,
//! CSV/JSON key, style), and each format renders any table through the one
//! `Exporter` trait, one file per format. The baseline grid, `eval`'s
//! summary and every `report` table are built this way.

mod csv;
mod html;
mod json;
mod markdown;
mod table;
mod text;

pub(crate) use csv::CsvExporter;
pub(crate) use html::{HtmlExporter, esc};
pub(crate) use json::JsonExporter;
pub(crate) use markdown::MarkdownExporter;
pub(crate) use table::{Cell, Column, Field, INCOMPLETE_MARK, Style, Table, f2, p_value, with_ci};
pub(crate) use text::TextExporter;

/// Renders a whole table in one format.
pub(crate) trait Exporter {
    fn render(&self, table: &Table) -> String;

    /// Several tables in one stream: each rendered, a blank line after
    /// each (the text formats, and CSV: one header line per table).
    fn render_all(&self, tables: &[Table]) -> String {
        tables.iter().map(|t| self.render(t) + "\n").collect()
    }
}

/// The formats a command prints on stdout (`--format`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// Aligned text for the terminal.
    Table,
    /// GitHub-flavoured Markdown.
    Md,
    Csv,
    Json,
}

impl Format {
    /// The exporter of this format; Markdown titles are level-3 headings.
    pub(crate) fn exporter(self) -> Box<dyn Exporter> {
        match self {
            Format::Table => Box::new(TextExporter),
            Format::Md => Box::new(MarkdownExporter { heading_level: 3 }),
            Format::Csv => Box::new(CsvExporter),
            Format::Json => Box::new(JsonExporter),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stats::Interval;

    /// Every kind of cell and column: a data-only and a display-only column,
    /// an identifier, intervals with and without bounds, a signed interval,
    /// a p-value, a rounded figure, a value with a share, and undefined
    /// values of each kind.
    fn demo() -> Table {
        let mut t = Table::new(
            "demo",
            "Demo | table",
            vec![
                Column::new("model", "model").style(Style::Code),
                Column::new("tier", "tier"),
                Column::data("seeds"),
                Column::new("success [95% CI]", "success").style(Style::Interval),
                Column::new("A − B", "diff").style(Style::SignedInterval),
                Column::new("p", "p").style(Style::PValue),
                Column::new("tokens/ep", "tokens").style(Style::Whole),
                Column::display("errors"),
            ],
        );
        t.push(vec![
            Cell::text("a|b"),
            Cell::Int(1),
            Cell::Int(20),
            Cell::Interval(Interval { estimate: 0.5, lo: 0.25, hi: 0.75 }),
            Cell::Interval(Interval { estimate: 0.1, lo: -0.04, hi: 0.3 }),
            Cell::Float(0.0004),
            Cell::Float(1234.4),
            Cell::WithParen(Box::new(Cell::Int(3)), Box::new(Cell::Percent(7.5))),
        ]);
        t.push(vec![
            Cell::text("<c>"),
            Cell::Int(3),
            Cell::Blank,
            Cell::Missing,
            Cell::estimate(f64::NAN),
            Cell::Float(0.25),
            Cell::Unknown,
            Cell::WithParen(Box::new(Cell::Int(0)), Box::new(Cell::Percent(0.0))),
        ]);
        t.note("n: a note");
        t
    }

    #[test]
    fn text() {
        insta::assert_snapshot!(TextExporter.render(&demo()), @r"
        Demo | table
        model  tier  success [95% CI]   A − B                 p       tokens/ep  errors
        -----  ----  -----------------  --------------------  ------  ---------  --------
        a|b    1     0.50 [0.25, 0.75]  +0.10 [-0.04, +0.30]  <0.001  1234       3 (7.5%)
        <c>    3     -                  -                     0.250   ?          0 (0.0%)
        n: a note
        ");
    }

    #[test]
    fn markdown() {
        let md = MarkdownExporter { heading_level: 2 }.render(&demo());
        // A note ends in a hard line break (two spaces), which the snapshot
        // comparison does not see.
        assert!(md.ends_with("\n\nn: a note  \n"), "{md:?}");
        insta::assert_snapshot!(md, @r"
        ## Demo | table

        | model | tier | success [95% CI] | A − B | p | tokens/ep | errors |
        |---|---|---|---|---|---|---|
        | `a\|b` | 1 | 0.50 [0.25, 0.75] | +0.10 [-0.04, +0.30] | <0.001 | 1234 | 3 (7.5%) |
        | `<c>` | 3 | - | - | 0.250 | ? | 0 (0.0%) |

        n: a note
        ");
    }

    #[test]
    fn csv() {
        insta::assert_snapshot!(CsvExporter.render(&demo()), @r"
        model,tier,seeds,success,success_lo,success_hi,diff,diff_lo,diff_hi,p,tokens
        a|b,1,20,0.5000,0.2500,0.7500,0.1000,-0.0400,0.3000,4.000000e-4,1234.4000
        <c>,3,,,,,,,,2.500000e-1,
        ");
    }

    #[test]
    fn json() {
        insta::assert_snapshot!(JsonExporter.render(&demo()), @r#"
        [
          {
            "model": "a|b",
            "tier": 1,
            "seeds": 20,
            "success": {
              "estimate": 0.5,
              "lo": 0.25,
              "hi": 0.75
            },
            "diff": {
              "estimate": 0.1,
              "lo": -0.04,
              "hi": 0.3
            },
            "p": 0.0004,
            "tokens": 1234.4
          },
          {
            "model": "<c>",
            "tier": 3,
            "seeds": null,
            "success": null,
            "diff": {
              "estimate": null,
              "lo": null,
              "hi": null
            },
            "p": 0.25,
            "tokens": null
          }
        ]
        "#);
    }

    #[test]
    fn html() {
        insta::assert_snapshot!(HtmlExporter.render(&demo()), @r#"<table class="t" data-table="demo"><caption>Demo | table</caption><thead><tr><th>model</th><th class="num">tier</th><th class="num">success [95% CI]</th><th class="num">A − B</th><th class="num">p</th><th class="num">tokens/ep</th><th class="num">errors</th></tr></thead><tbody><tr><td>a|b</td><td class="num">1</td><td class="num">0.50 [0.25, 0.75]</td><td class="num">+0.10 [-0.04, +0.30]</td><td class="num">&lt;0.001</td><td class="num">1234</td><td class="num">3 (7.5%)</td></tr><tr><td>&lt;c&gt;</td><td class="num">3</td><td class="num">-</td><td class="num">-</td><td class="num">0.250</td><td class="num">?</td><td class="num">0 (0.0%)</td></tr></tbody></table><p class="note">n: a note</p>"#);
    }

    #[test]
    fn a_row_of_the_wrong_length_is_refused() {
        let mut t = demo();
        let pushed = std::panic::catch_unwind(move || t.push(vec![Cell::Blank]));
        assert!(pushed.is_err());
    }

    #[test]
    fn html_escapes_every_special_character() {
        assert_eq!(esc("a&'\"<>"), "a&amp;&#39;&quot;&lt;&gt;");
    }
}
