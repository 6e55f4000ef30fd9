//! The model configuration's unit tests.

use super::*;

#[test]
fn the_kernel_is_written_only_when_it_is_not_the_papers() {
    let paper = ModelConfig::new(Variant::Attention);
    let json = serde_json::to_string(&paper).unwrap();
    assert!(!json.contains("conv_kernel"), "{json}");
    // Checkpoints written before the field existed read as 3×3.
    let back: ModelConfig = serde_json::from_str(&json).unwrap();
    assert_eq!(back, paper);
    let one = ModelConfig {
        conv_kernel: 1,
        ..paper
    };
    let json = serde_json::to_string(&one).unwrap();
    assert!(json.contains("\"conv_kernel\":1"), "{json}");
    assert_eq!(serde_json::from_str::<ModelConfig>(&json).unwrap(), one);
}

#[test]
fn the_filter_scale_is_written_only_when_it_is_the_papers() {
    let ours = ModelConfig::new(Variant::Attention);
    assert!(
        !serde_json::to_string(&ours)
            .unwrap()
            .contains("filter_scale")
    );
    let papers = ModelConfig {
        filter_scale: 1,
        ..ours
    };
    let json = serde_json::to_string(&papers).unwrap();
    assert!(json.contains("\"filter_scale\":1"), "{json}");
    assert_eq!(serde_json::from_str::<ModelConfig>(&json).unwrap(), papers);
    for (s, ok) in [(0, false), (1, true), (7, false), (49, true)] {
        let r = ModelConfig {
            filter_scale: s,
            ..ours
        }
        .validate();
        assert_eq!(r.is_ok(), ok, "{s}: {r:?}");
    }
}

#[test]
fn colour_codes_are_written_only_when_not_minigrids() {
    let all = ModelConfig::new(Variant::Attention);
    let json = serde_json::to_string(&all).unwrap();
    assert!(!json.contains("colour_codes"), "{json}");
    assert_eq!(serde_json::from_str::<ModelConfig>(&json).unwrap(), all);
    let objects = ModelConfig {
        colour_codes: ColourCodes::parse("objects").unwrap(),
        ..all
    };
    let json = serde_json::to_string(&objects).unwrap();
    assert!(json.contains("\"colour_codes\":\"objects\""), "{json}");
    assert_eq!(serde_json::from_str::<ModelConfig>(&json).unwrap(), objects);
    let walls = ModelConfig {
        colour_codes: ColourCodes::parse("walls-objects").unwrap(),
        ..all
    };
    let json = serde_json::to_string(&walls).unwrap();
    assert!(
        json.contains("\"colour_codes\":\"walls-objects\""),
        "{json}"
    );
    assert_eq!(serde_json::from_str::<ModelConfig>(&json).unwrap(), walls);
    let bad = ColourCodes::parse("none").unwrap_err().to_string();
    assert!(bad.contains("colour_codes = none"), "{bad}");
}

#[test]
fn the_word_temperature_is_written_only_when_not_the_papers_and_must_be_positive() {
    let paper = ModelConfig::new(Variant::Attention);
    let json = serde_json::to_string(&paper).unwrap();
    assert!(!json.contains("word_temperature"), "{json}");
    let warm = ModelConfig {
        word_temperature: WordTemperature(3.89),
        ..paper
    };
    let json = serde_json::to_string(&warm).unwrap();
    assert!(json.contains("\"word_temperature\":3.89"), "{json}");
    assert_eq!(serde_json::from_str::<ModelConfig>(&json).unwrap(), warm);
    for (t, ok) in [
        (1.0, true),
        (0.5, true),
        (100.0, true),
        (0.01, true),
        (0.009, false),
        (1e-45, false),
        (0.0, false),
        (-1.0, false),
        (100.5, false),
        (f32::INFINITY, false),
        (f32::NAN, false),
    ] {
        let r = ModelConfig {
            word_temperature: WordTemperature(t),
            ..paper
        }
        .validate();
        assert_eq!(r.is_ok(), ok, "{t}: {r:?}");
        if !ok {
            assert!(format!("{r:?}").contains("word_temperature"), "{r:?}");
        }
    }
}

#[test]
fn search_query_is_written_only_when_set_and_needs_shared_attention_keys() {
    let plain = ModelConfig::new(Variant::Attention);
    let json = serde_json::to_string(&plain).unwrap();
    assert!(!json.contains("search_query"), "{json}");
    let search = ModelConfig {
        search_query: true,
        ..plain
    };
    let json = serde_json::to_string(&search).unwrap();
    assert!(json.contains("\"search_query\":true"), "{json}");
    assert_eq!(serde_json::from_str::<ModelConfig>(&json).unwrap(), search);
    assert!(search.validate().is_ok());
    assert_eq!(search.lstm_input_size(), 2 * plain.lstm_input_size());
    for bad in [
        ModelConfig {
            key_kernel: Some(1),
            ..search
        },
        ModelConfig {
            search_query: true,
            ..ModelConfig::new(Variant::Baseline)
        },
    ] {
        let e = bad.validate().unwrap_err().to_string();
        assert!(e.contains("search_query"), "{e}");
    }
}

#[test]
fn null_key_is_written_only_when_set_and_needs_attention_without_search() {
    let plain = ModelConfig::new(Variant::Attention);
    let null = ModelConfig {
        null_key: true,
        key_kernel: Some(1),
        ..plain
    };
    let json = serde_json::to_string(&null).unwrap();
    assert!(json.contains("\"null_key\":true"), "{json}");
    assert!(!serde_json::to_string(&plain).unwrap().contains("null_key"));
    assert_eq!(serde_json::from_str::<ModelConfig>(&json).unwrap(), null);
    assert!(null.validate().is_ok());
    assert_eq!(null.lstm_input_size(), plain.lstm_input_size());
    for bad in [
        ModelConfig {
            search_query: true,
            key_kernel: None,
            ..null
        },
        ModelConfig {
            null_key: true,
            ..ModelConfig::new(Variant::Baseline)
        },
    ] {
        let e = bad.validate().unwrap_err().to_string();
        assert!(e.contains("null_key"), "{e}");
    }
}

#[test]
fn key_context_is_written_only_when_set_and_needs_split_keys() {
    let split = ModelConfig {
        key_kernel: Some(1),
        ..ModelConfig::new(Variant::Attention)
    };
    let context = ModelConfig {
        key_context: true,
        ..split
    };
    let json = serde_json::to_string(&context).unwrap();
    assert!(json.contains("\"key_context\":true"), "{json}");
    assert!(
        !serde_json::to_string(&split)
            .unwrap()
            .contains("key_context")
    );
    assert_eq!(serde_json::from_str::<ModelConfig>(&json).unwrap(), context);
    assert!(context.validate().is_ok());
    for bad in [
        ModelConfig {
            key_kernel: None,
            ..context
        },
        ModelConfig {
            null_key: true,
            ..context
        },
        ModelConfig {
            key_context: true,
            ..ModelConfig::new(Variant::Baseline)
        },
    ] {
        let e = bad.validate().unwrap_err().to_string();
        assert!(e.contains("key_context"), "{e}");
    }
}

#[test]
fn split_keys_are_written_only_when_set_and_only_for_attention() {
    let shared = ModelConfig::new(Variant::Attention);
    let json = serde_json::to_string(&shared).unwrap();
    assert!(!json.contains("key_kernel"), "{json}");
    assert_eq!(serde_json::from_str::<ModelConfig>(&json).unwrap(), shared);
    let split = ModelConfig {
        key_kernel: Some(1),
        ..shared
    };
    let json = serde_json::to_string(&split).unwrap();
    assert!(json.contains("\"key_kernel\":1"), "{json}");
    assert_eq!(serde_json::from_str::<ModelConfig>(&json).unwrap(), split);
    assert!(split.validate().is_ok());
    for bad in [
        ModelConfig {
            key_kernel: Some(2),
            ..shared
        },
        ModelConfig {
            key_kernel: Some(1),
            ..ModelConfig::new(Variant::Baseline)
        },
    ] {
        let e = bad.validate().unwrap_err().to_string();
        assert!(e.contains("key_kernel"), "{e}");
    }
}

#[test]
fn only_one_and_three_are_kernels() {
    for (k, ok) in [(0, false), (1, true), (2, false), (3, true), (5, false)] {
        let cfg = ModelConfig {
            conv_kernel: k,
            ..ModelConfig::new(Variant::Baseline)
        };
        let r = cfg.validate();
        assert_eq!(r.is_ok(), ok, "{k}: {r:?}");
        if let Err(e) = r {
            assert!(e.to_string().contains("conv_kernel"), "{e}");
        }
    }
}

#[test]
fn content_words_mask_the_function_words_and_are_written_only_when_set() {
    use crate::env::vocab::tokenize;
    let all = ModelConfig::new(Variant::Attention);
    let content = ModelConfig {
        attend_words: AttendWords::Content,
        ..all
    };
    assert!(
        !serde_json::to_string(&all)
            .unwrap()
            .contains("attend_words")
    );
    let json = serde_json::to_string(&content).unwrap();
    assert!(json.contains("\"attend_words\":\"content\""), "{json}");
    assert_eq!(serde_json::from_str::<ModelConfig>(&json).unwrap(), content);
    let go = tokenize("go to the red ball").unwrap();
    assert_eq!(AttendWords::Content.mask(&go), [0.0, 0.0, 0.0, 1.0, 1.0]);
    assert_eq!(AttendWords::All.mask(&go), [1.0; 5]);
    let pick = tokenize("pick up a key").unwrap();
    assert_eq!(AttendWords::Content.mask(&pick), [0.0, 0.0, 0.0, 1.0]);
    // No content word: every word is kept rather than none.
    let bare = tokenize("go to the object").unwrap();
    assert_eq!(AttendWords::Content.mask(&bare), [1.0; 4]);
    assert!(
        AttendWords::parse("some")
            .unwrap_err()
            .to_string()
            .contains("attend_words")
    );
    let e = ModelConfig {
        attend_words: AttendWords::Content,
        ..ModelConfig::new(Variant::Baseline)
    }
    .validate()
    .unwrap_err()
    .to_string();
    assert!(e.contains("attend_words"), "{e}");
}
