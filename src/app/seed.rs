//! The seed field: a text field exact for every `u64` seed, which follows what is typed and
//! the seed set elsewhere ("next seed", a report's episode).

use eframe::egui;

/// The seed field's text and the seed it was last in step with (kept in egui's memory from
/// frame to frame).
#[derive(Clone, Debug, PartialEq, Eq)]
struct SeedText {
    seed: u64,
    text: String,
}

impl SeedText {
    /// The field showing `seed`.
    fn new(seed: u64) -> Self {
        Self {
            seed,
            text: seed.to_string(),
        }
    }

    /// Shows `seed` again where it was changed elsewhere ("next seed", an episode of a
    /// report); what is being typed for the seed it holds stays.
    fn sync(&mut self, seed: u64) {
        if self.seed != seed {
            *self = Self::new(seed);
        }
    }

    /// After an edit: the seed the text now reads as, if it reads as one.
    fn edited(&mut self) -> Option<u64> {
        let seed = parse_seed(&self.text)?;
        self.seed = seed;
        Some(seed)
    }

    /// The field left: text that is not the seed goes back to the seed's digits.
    fn left(&mut self) {
        if parse_seed(&self.text) != Some(self.seed) {
            self.text = self.seed.to_string();
        }
    }
}

/// A seed as typed: a whole number from 0 to 2⁶⁴ − 1 (spaces around it and `_` between
/// digits allowed), exactly.
fn parse_seed(text: &str) -> Option<u64> {
    let digits: String = text.trim().chars().filter(|&c| c != '_').collect();
    if digits.is_empty() || !digits.chars().all(|c| c.is_ascii_digit()) {
        return None;
    }
    digits.parse().ok()
}

/// The seed as a text field, exact for every `u64`: egui's `DragValue` holds its value as an
/// `f64` and rounded seeds above 2⁵³ (`view --seed 9007199254740993` showed …992 and ran
/// it). While the field is edited the seed follows every text that reads as one; left with
/// text that does not, the field shows the seed again.
pub(in crate::app) fn seed_field(ui: &mut egui::Ui, seed: &mut u64) {
    let id = ui.make_persistent_id("seed_text");
    let mut field = ui
        .ctx()
        .data_mut(|d| d.get_temp::<SeedText>(id))
        .unwrap_or_else(|| SeedText::new(*seed));
    field.sync(*seed);
    let r = ui
        .add(egui::TextEdit::singleline(&mut field.text).desired_width(150.0))
        .on_hover_text("the level seed: a whole number from 0 to 18446744073709551615");
    if r.changed()
        && let Some(s) = field.edited()
    {
        *seed = s;
    }
    if r.lost_focus() {
        field.left();
    }
    ui.ctx().data_mut(|d| d.insert_temp(id, field));
}

#[cfg(test)]
mod tests {
    use super::{SeedText, parse_seed};

    #[test]
    fn every_u64_seed_reads_back_exactly() {
        // Above 2⁵³ an f64 rounds: 2⁵³ + 1 used to show and run as 2⁵³.
        for seed in [
            0,
            7,
            (1 << 53) + 1,
            9_007_199_254_740_993,
            u64::MAX - 1,
            u64::MAX,
        ] {
            let field = SeedText::new(seed);
            assert_eq!(field.text, seed.to_string());
            assert_eq!(parse_seed(&field.text), Some(seed));
        }
        assert_eq!(parse_seed(" 1_000 "), Some(1000));
        for bad in ["", "-1", "1.5", "1e3", "18446744073709551616", "seed", "+3"] {
            assert_eq!(parse_seed(bad), None, "{bad:?}");
        }
    }

    #[test]
    fn the_field_follows_what_is_typed_and_the_seed_set_elsewhere() {
        let mut field = SeedText::new(3);
        // Typed: the seed follows each text that reads as one, exactly.
        field.text = "18446744073709551615".into();
        assert_eq!(field.edited(), Some(u64::MAX));
        // Cleared while typing: the seed stays, the text too, until the field is left.
        field.text.clear();
        assert_eq!(field.edited(), None);
        field.sync(u64::MAX);
        assert_eq!(field.text, "");
        field.left();
        assert_eq!(field.text, "18446744073709551615");
        // "next seed" or a report's episode: the field shows the new seed.
        field.sync(9_007_199_254_740_993);
        assert_eq!(field.text, "9007199254740993");
    }
}
