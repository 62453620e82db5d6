use super::*;

fn board() -> Board {
    Board::new(
        Limits {
            roll_deg: 2.5,
            pitch_deg: 1.5,
        },
        Duration::from_secs(3),
    )
}

fn forecast(seq: u64, heave: f32, roll_rad: f32) -> Forecast {
    let mut f = Forecast {
        seq,
        time_s: seq as f64 * 0.5,
        dt_s: 0.5,
        steps: 4,
        model_version: 1,
        ..Forecast::default()
    };
    for k in 0..4 {
        f.mean[Dof::Heave.index()][k] = heave;
        f.sigma[Dof::Heave.index()][k] = 0.1 * (k + 1) as f32;
        f.mean[Dof::Roll.index()][k] = roll_rad;
    }
    f
}

#[test]
fn a_forecast_is_shown_in_metres_and_degrees_with_only_its_valid_steps() {
    let b = board();
    let t0 = Instant::now();
    b.forecast(
        "ddg51",
        &forecast(7, 1.25, std::f32::consts::PI / 180.0),
        t0,
    )
    .unwrap();
    let s = b.snapshot(t0);
    assert_eq!(s.vessels.len(), 1);
    let v = &s.vessels[0];
    assert!(!v.stale);
    let f = v.forecast.as_ref().unwrap();
    assert_eq!(f.seq, 7);
    assert_eq!(f.heave.mean, vec![1.25; 4]);
    assert_eq!(f.heave.sigma.len(), 4);
    assert!((f.heave.sigma[3] - 0.4).abs() < 1e-6);
    assert!(
        f.roll.mean.iter().all(|r| (r - 1.0).abs() < 1e-5),
        "{:?}",
        f.roll
    );
}

#[test]
fn a_repeated_or_older_seq_from_a_live_vessel_is_refused_and_counted() {
    let b = board();
    let t0 = Instant::now();
    b.forecast("a", &forecast(10, 1.0, 0.0), t0).unwrap();
    let t1 = t0 + Duration::from_millis(500);
    assert_eq!(
        b.forecast("a", &forecast(10, 9.99, 0.0), t1),
        Err(Refused::Seq { last: 10, got: 10 })
    );
    assert!(b.forecast("a", &forecast(3, 9.99, 0.0), t1).is_err());
    let v = &b.snapshot(t1).vessels[0];
    assert_eq!(v.rejected, 2);
    assert_eq!(
        v.forecast.as_ref().unwrap().heave.mean[0],
        1.0,
        "the forgery is not shown"
    );
}

#[test]
fn made_up_vessel_and_station_names_are_bounded_and_counted() {
    // Regression: every vessel name a key carried (forged ones included, even in a
    // malformed message) was kept for good and sent to every page.
    let b = board();
    let t0 = Instant::now();
    for i in 0..MAX_VESSELS {
        b.forecast(&format!("v{i}"), &forecast(1, 1.0, 0.0), t0)
            .unwrap();
    }
    assert_eq!(
        b.forecast("one-too-many", &forecast(1, 1.0, 0.0), t0),
        Err(Refused::BeyondBounds)
    );
    // A refused message makes no entry: counted apart.
    b.reject("another");
    // A vessel already held is still served.
    b.forecast("v0", &forecast(2, 2.0, 0.0), t0).unwrap();
    let s = b.snapshot(t0);
    assert_eq!(s.vessels.len(), MAX_VESSELS);
    assert_eq!((s.beyond_bounds, s.rejected_unheard), (1, 1));
    assert!(s.vessels.iter().all(|v| v.vessel != "another"));
    let mut advisor = shipcast_pipeline::deck::DeckAdvisor::new(
        &shipcast_pipeline::config::DeckConfig::default(),
    );
    let json = serde_json::to_vec(&advisor.advise(&calm_forecast(50))).unwrap();
    for i in 0..=MAX_STATIONS {
        let a: AdvisoryView = serde_json::from_slice(&json).unwrap();
        b.advisory("v1", &format!("s{i}"), a, t0);
    }
    let s = b.snapshot(t0);
    let v1 = s.vessels.iter().find(|v| v.vessel == "v1").unwrap();
    assert_eq!(v1.advisories.len(), MAX_STATIONS);
    assert_eq!(s.beyond_bounds, 2);
}

/// Regression: junk on 64 made-up vessel keys filled the board with entries that never
/// had a forecast, and a real vessel was kept off it for good.
#[test]
fn a_full_board_makes_room_for_a_live_vessel_by_dropping_the_stalest() {
    let b = board();
    let t0 = Instant::now();
    let stale_after = Duration::from_secs_f64(b.snapshot(t0).stale_after_s);
    // 63 vessels that once sent a forecast, at t0, and one that never did (an advisory
    // alone makes an entry).
    for i in 0..MAX_VESSELS - 1 {
        b.forecast(&format!("v{i}"), &forecast(1, 1.0, 0.0), t0)
            .unwrap();
    }
    let json = serde_json::to_vec(
        &shipcast_pipeline::deck::DeckAdvisor::new(
            &shipcast_pipeline::config::DeckConfig::default(),
        )
        .advise(&calm_forecast(50)),
    )
    .unwrap();
    b.advisory("never", "deck", serde_json::from_slice(&json).unwrap(), t0);
    // While all the others are live, the one that never sent a forecast makes room.
    b.forecast("real", &forecast(1, 1.0, 0.0), t0).unwrap();
    let names = |t| -> Vec<String> {
        b.snapshot(t)
            .vessels
            .into_iter()
            .map(|v| v.vessel)
            .collect()
    };
    assert!(!names(t0).contains(&"never".to_string()));
    assert_eq!(names(t0).len(), MAX_VESSELS);
    // A board of live vessels refuses the next one.
    assert_eq!(
        b.forecast("late", &forecast(1, 1.0, 0.0), t0),
        Err(Refused::BeyondBounds)
    );
    // Once they are stale, the stalest (v0..v62 at t0; "real" refreshed later) go first.
    let later = t0 + stale_after + Duration::from_secs(1);
    b.forecast("real", &forecast(2, 1.0, 0.0), later).unwrap();
    b.forecast("late", &forecast(1, 1.0, 0.0), later).unwrap();
    let now = names(later);
    assert!(now.contains(&"late".to_string()) && now.contains(&"real".to_string()));
    assert_eq!(now.len(), MAX_VESSELS);
}

/// A calm forecast of `steps` steps: every motion small, sigma small.
fn calm_forecast(steps: usize) -> Forecast {
    let mut f = Forecast {
        seq: 7,
        time_s: 100.0,
        dt_s: 0.5,
        steps: steps as u32,
        ..Forecast::default()
    };
    for d in 0..6 {
        for k in 0..steps {
            f.mean[d][k] = 0.001;
            f.sigma[d][k] = 0.001;
        }
    }
    f
}

#[test]
fn the_deck_advisory_the_deck_publishes_parses_with_its_decision() {
    // The real advisor's JSON, not a copy of its shape: a drift between the two fails here.
    use shipcast_pipeline::config::DeckConfig;
    use shipcast_pipeline::deck::DeckAdvisor;
    // A fresh deck has verified no forecast yet: no probability, no go.
    let mut fresh = DeckAdvisor::new(&DeckConfig::default());
    let json = serde_json::to_vec(&fresh.advise(&calm_forecast(50))).unwrap();
    let a: AdvisoryView = serde_json::from_slice(&json).unwrap();
    // What the real deck publishes passes the check the board makes of every advisory.
    a.check().unwrap();
    assert!(!a.decision.go && a.decision.ensemble_members == Some(0));
    assert_eq!(a.decision.probability_now, None);
    assert!(a.decision.awaiting_verified_errors);
    let mut advisor = DeckAdvisor::new(&DeckConfig {
        go_needs_verified_errors: false,
        ..DeckConfig::default()
    });
    let json = serde_json::to_vec(&advisor.advise(&calm_forecast(50))).unwrap();
    let a: AdvisoryView = serde_json::from_slice(&json).unwrap();
    // What the real deck publishes passes the check the board makes of every advisory.
    a.check().unwrap();
    assert_eq!(a.time_s, 100.0);
    assert!(a.max_roll_deg.is_some() && a.max_pitch_deg.is_some());
    // A calm sea with tiny sigma: go now, no exceedance.
    assert!(a.decision.go, "{:?}", a.decision);
    assert!(a.decision.probability_now.unwrap() > 0.99);
    assert_eq!(a.decision.next_exceedance_s, None);
    // A heave far beyond the displacement limit from step 20 on: no go later.
    let mut f = calm_forecast(50);
    for k in 20..50 {
        f.mean[2][k] = 10.0;
    }
    let json = serde_json::to_vec(&advisor.advise(&f)).unwrap();
    let a: AdvisoryView = serde_json::from_slice(&json).unwrap();
    // What the real deck publishes passes the check the board makes of every advisory.
    a.check().unwrap();
    assert!(a.decision.next_exceedance_s.unwrap() > 9.0);
}

#[test]
fn a_frozen_sensor_named_by_the_deck_reaches_the_page_and_a_made_up_one_is_refused() {
    use shipcast_pipeline::config::DeckConfig;
    use shipcast_pipeline::deck::DeckAdvisor;
    let mut advisor = DeckAdvisor::new(&DeckConfig {
        go_needs_verified_errors: false,
        ..DeckConfig::default()
    });
    // Heave moves, then repeats its value for a minute: the deck names it.
    let mut json = Vec::new();
    for i in 0..300 {
        let t = 100.0 + 0.5 * i as f64;
        let heave = if i < 100 { (0.1 * i as f64).sin() } else { 0.5 };
        let f = Forecast {
            time_s: t,
            ..calm_forecast(50)
        };
        json =
            serde_json::to_vec(&advisor.advise_from(&f, Some(&[0.0, 0.0, heave, 0.0, 0.0, 0.0])))
                .unwrap();
    }
    let a: AdvisoryView = serde_json::from_slice(&json).unwrap();
    a.check().unwrap();
    assert_eq!(a.decision.frozen_dof, Some(Dof::Heave));
    assert!(!a.decision.go && a.decision.probability_now.is_none());
    // Only a DOF's name is taken: anything else in the field is a forged advisory.
    let text = String::from_utf8(json).unwrap();
    let forged = text.replace("\"frozen_dof\":\"heave\"", "\"frozen_dof\":\"<b>deck</b>\"");
    assert_ne!(forged, text);
    assert!(serde_json::from_str::<AdvisoryView>(&forged).is_err());
}

#[test]
fn a_lift_advisory_parses_and_a_message_without_a_decision_is_refused() {
    let lift = serde_json::json!({
        "crane_vessel": "a", "target_vessel": "b", "time_s": 12.5,
        "decision": {"mot_s": 10.0, "go_probability": 0.9, "go": false,
                     "probability_now": 0.4, "next_exceedance_s": 3.0}
    });
    let a: AdvisoryView = serde_json::from_value(lift).unwrap();
    assert!(!a.decision.go);
    assert_eq!(a.decision.next_window_s, None);
    assert_eq!(a.max_roll_deg, None);
    // A lift stopped by a frozen sensor names the ship; any other ship is a forged advisory.
    let frozen = serde_json::json!({
        "crane_vessel": "a", "target_vessel": "b", "time_s": 12.5,
        "decision": {"mot_s": 10.0, "go_probability": 0.9, "go": false,
                     "probability_now": null, "next_exceedance_s": null,
                     "frozen_ship": "target", "frozen_dof": "roll"}
    });
    let a: AdvisoryView = serde_json::from_value(frozen.clone()).unwrap();
    a.check().unwrap();
    assert_eq!(
        (a.decision.frozen_ship, a.decision.frozen_dof),
        (
            Some(shipcast_pipeline::relative::still::Ship::Target),
            Some(Dof::Roll)
        )
    );
    let mut forged = frozen;
    forged["decision"]["frozen_ship"] = serde_json::json!("<b>b</b>");
    assert!(serde_json::from_value::<AdvisoryView>(forged).is_err());
    let old = serde_json::json!({"forecast_seq": 1, "time_s": 1.0, "windows": []});
    assert!(serde_json::from_value::<AdvisoryView>(old).is_err());
}

/// Regression: a predictor restarted within the stale limit counts seq from 0 again; its
/// forecasts were refused and the dead one's last forecast stayed on the page as live.
#[test]
fn a_new_publisher_starts_its_own_seq_and_one_stream_must_move_forward() {
    let b = board();
    let t0 = Instant::now();
    b.forecast_from("a", &forecast(49, 1.0, 0.0), Some("old"), t0)
        .unwrap();
    let t1 = t0 + Duration::from_secs(1);
    assert!(b
        .forecast_from("a", &forecast(48, 1.5, 0.0), Some("old"), t1)
        .is_err());
    b.forecast_from("a", &forecast(0, 2.0, 0.0), Some("new"), t1)
        .unwrap();
    let s = b.snapshot(t1);
    assert_eq!(s.vessels[0].forecast.as_ref().unwrap().seq, 0);
    // Within the new stream seq must move forward again.
    assert!(b
        .forecast_from("a", &forecast(0, 2.5, 0.0), Some("new"), t1)
        .is_err());
    b.forecast_from("a", &forecast(1, 2.5, 0.0), Some("new"), t1)
        .unwrap();
}

#[test]
fn a_vessel_without_forecasts_for_longer_than_the_limit_is_stale_and_shows_none() {
    let b = board();
    let t0 = Instant::now();
    b.forecast("a", &forecast(1, 1.0, 0.0), t0).unwrap();
    b.advisory(
        "a",
        "deck",
        AdvisoryView {
            time_s: 0.5,
            max_roll_deg: Some(1.0),
            max_pitch_deg: Some(1.0),
            decision: DecisionView {
                mot_s: 10.0,
                go_probability: 0.95,
                go: true,
                probability_now: Some(0.97),
                next_window_s: Some(0.0),
                next_window_probability: Some(0.97),
                next_exceedance_s: None,
                ensemble_members: Some(300),
                awaiting_verified_errors: false,
                frozen_dof: None,
                frozen_ship: None,
            },
            stale_s: None,
        },
        t0,
    );
    let just_in_time = b.snapshot(t0 + Duration::from_secs(3));
    assert_eq!(just_in_time.vessels[0].advisories["deck"].stale_s, None);
    assert!(!just_in_time.vessels[0].stale);
    assert_eq!(just_in_time.vessels[0].advisories.len(), 1);
    let late = b.snapshot(t0 + Duration::from_millis(3001));
    let v = &late.vessels[0];
    assert!(v.stale);
    assert!(v.forecast.is_none() && v.advisories.is_empty());
    assert!((v.age_s.unwrap() - 3.001).abs() < 1e-9);
    // After a gap a restarted predictor's seq 0 is accepted again.
    let later = t0 + Duration::from_secs(10);
    b.forecast("a", &forecast(0, 2.0, 0.0), later).unwrap();
    let back = b.snapshot(later);
    assert!(!back.vessels[0].stale);
    // Regression: the deck that died with it came back as current with its old GO. Its
    // advisory is 10 s old: shown, but marked stale with its age.
    let deck = &back.vessels[0].advisories["deck"];
    assert!(deck.decision.go);
    assert!((deck.stale_s.unwrap() - 10.0).abs() < 1e-9, "{deck:?}");
    // And while forecasts keep coming but the deck is silent, the same.
    b.forecast("a", &forecast(1, 2.5, 0.0), later + Duration::from_secs(1))
        .unwrap();
    let s = b.snapshot(later + Duration::from_secs(1));
    assert!(!s.vessels[0].stale);
    assert!(s.vessels[0].advisories["deck"].stale_s.unwrap() > 10.0);
}

#[test]
fn skill_is_read_at_5_10_and_20_s_and_a_bad_report_is_counted() {
    let b = board();
    let report: VerificationIn = serde_json::from_str(
        r#"{"window_s":1200,"dt_s":0.5,"dofs":[
            {"dof":"heave","nrmse_zero":[0.1,0.2,0.3,0.4,0.5,0.6,0.7,0.8,0.9,0.91],"skill_horizon_s":3.5},
            {"dof":"surge","nrmse_zero":[0.5],"skill_horizon_s":1.0}]}"#,
    )
    .unwrap();
    let t0 = Instant::now();
    b.forecast("a", &forecast(1, 1.0, 0.0), t0).unwrap();
    assert!(b.verification("a", &report, t0));
    let s = b.snapshot(t0);
    let skill = &s.vessels[0].skill;
    assert_eq!(skill.len(), 1, "only heave, roll and pitch are shown");
    // 5 s at 2 Hz is step 10 (index 9); 10 and 20 s lie beyond this report's steps.
    assert_eq!(skill[0].nrmse_at, [Some(0.91), None, None]);
    assert_eq!(skill[0].skill_horizon_s, 3.5);
    let bad = VerificationIn {
        dt_s: 0.0,
        dofs: vec![],
    };
    assert!(!b.verification("a", &bad, t0));
    assert_eq!(b.snapshot(t0).vessels[0].rejected, 1);
    // A stale vessel's skill is its silent predictor's: withheld with its forecast.
    let stale = b.snapshot(t0 + Duration::from_secs(4));
    assert!(stale.vessels[0].stale && stale.vessels[0].skill.is_empty());
}

#[test]
fn the_snapshot_is_json_the_page_can_read() {
    let b = board();
    b.forecast("ddg51", &forecast(1, 0.5, 0.0), Instant::now())
        .unwrap();
    let v: serde_json::Value = serde_json::from_str(&b.snapshot_json(Instant::now())).unwrap();
    assert_eq!(v["vessels"][0]["vessel"], "ddg51");
    assert_eq!(v["limits"]["roll_deg"], 2.5);
    assert_eq!(v["vessels"][0]["forecast"]["heave"]["mean"][0], 0.5);
}

/// A lift advisory as `shipcast relative` publishes it, with `go` and its probability.
fn lift_advisory(go: bool, probability_now: Option<f64>) -> AdvisoryView {
    serde_json::from_value(serde_json::json!({
        "time_s": 12.5,
        "decision": {"mot_s": 10.0, "go_probability": 0.9, "go": go,
                     "probability_now": probability_now, "next_exceedance_s": null}
    }))
    .unwrap()
}

/// Regression (review): a forged `go: true` without a probability was drawn as a green
/// "NO-GO", and numbers out of any range went on the page as they came.
#[test]
fn an_advisory_that_makes_no_sense_is_refused_and_counted() {
    let b = board();
    let t0 = Instant::now();
    b.forecast("a", &forecast(1, 1.0, 0.0), t0).unwrap();
    assert!(b.advisory("a", "lift", lift_advisory(true, Some(0.93)), t0));
    assert!(b.advisory("a", "lift", lift_advisory(false, Some(0.5)), t0));
    let mut refused = vec![
        lift_advisory(true, None),
        lift_advisory(true, Some(0.89)),
        lift_advisory(false, Some(1.5)),
        lift_advisory(false, Some(-0.1)),
    ];
    let mut a = lift_advisory(false, Some(0.5));
    a.decision.mot_s = 1e300 * 1e300;
    refused.push(a);
    let mut a = lift_advisory(false, Some(0.5));
    a.decision.next_exceedance_s = Some(-3.0);
    refused.push(a);
    let mut a = lift_advisory(false, Some(0.5));
    a.decision.go_probability = 0.0;
    refused.push(a);
    // A go that contradicts its own station's state (review): awaiting verified errors, or
    // with a frozen sensor on either ship.
    let mut a = lift_advisory(true, Some(0.95));
    a.decision.awaiting_verified_errors = true;
    refused.push(a);
    let mut a = lift_advisory(true, Some(0.95));
    a.decision.frozen_dof = Some(shipcast_wire::Dof::Heave);
    refused.push(a);
    let mut a = lift_advisory(true, Some(0.95));
    a.decision.frozen_ship = Some(shipcast_pipeline::relative::still::Ship::Target);
    refused.push(a);
    let n = refused.len() as u64;
    for a in refused {
        assert!(!b.advisory("a", "lift", a, t0));
    }
    let v = &b.snapshot(t0).vessels[0];
    assert_eq!(v.rejected, n);
    // The last sound one is what stays shown.
    assert_eq!(v.advisories["lift"].decision.probability_now, Some(0.5));
}

/// Regression (review): a report repeating heave 100 000 times kept 100 000 skill rows, sent
/// to every page twice a second.
#[test]
fn a_report_repeating_a_dof_keeps_one_row_per_dof() {
    let b = board();
    let t0 = Instant::now();
    b.forecast("a", &forecast(1, 1.0, 0.0), t0).unwrap();
    let row = |x: f64| DofVerificationIn {
        dof: "heave".into(),
        nrmse_zero: vec![Some(x); 10],
        skill_horizon_s: Some(2.0),
    };
    let mut dofs: Vec<_> = (0..1000).map(|i| row(0.5 + i as f64 * 1e-4)).collect();
    dofs.push(DofVerificationIn {
        dof: "pitch".into(),
        nrmse_zero: vec![Some(0.7); 10],
        skill_horizon_s: None,
    });
    assert!(b.verification("a", &VerificationIn { dt_s: 0.5, dofs }, t0));
    let skill = &b.snapshot(t0).vessels[0].skill;
    let names: Vec<_> = skill.iter().map(|s| s.dof.as_str()).collect();
    assert_eq!(names, ["heave", "pitch"]);
    assert_eq!(skill[0].nrmse_at[0], Some(0.5), "the first heave row");
}

/// Regression (review): skill has no age of its own; a dead predictor's skill came back
/// beside a new predictor's forecasts as if current.
#[test]
fn skill_no_report_renews_is_withheld_though_forecasts_keep_coming() {
    let b = board();
    let t0 = Instant::now();
    b.forecast_from("a", &forecast(1, 1.0, 0.0), Some("old"), t0)
        .unwrap();
    let report = VerificationIn {
        dt_s: 0.5,
        dofs: vec![DofVerificationIn {
            dof: "roll".into(),
            nrmse_zero: vec![Some(0.4); 10],
            skill_horizon_s: Some(8.0),
        }],
    };
    assert!(b.verification("a", &report, t0));
    assert_eq!(b.snapshot(t0).vessels[0].skill.len(), 1);
    // A new predictor's forecasts arrive 10 s later; no report has come since.
    let later = t0 + Duration::from_secs(10);
    b.forecast_from("a", &forecast(0, 1.0, 0.0), Some("new"), later)
        .unwrap();
    let v = &b.snapshot(later).vessels[0];
    assert!(!v.stale);
    assert!(v.skill.is_empty(), "{:?}", v.skill);
    // Its own report brings the skill back.
    assert!(b.verification("a", &report, later));
    assert_eq!(b.snapshot(later).vessels[0].skill.len(), 1);
}
