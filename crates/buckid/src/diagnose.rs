//! `buckid diagnose`: where, which and how far, for a data file against the averaged model.
use anyhow::{Context, Result};
use estimator::data::DataSet;
use gap::{DiagnoseOptions, diagnose};

use crate::DiagnoseArgs;
use crate::identify::nominal_from;

/// Runs the command.
pub fn run(args: &DiagnoseArgs) -> Result<()> {
    eprintln!("reading {}", args.data.display());
    let data = DataSet::read_csv(&args.data)?;
    let (nominal, assumed) = nominal_from(&data)?;
    for a in &assumed {
        eprintln!("assuming {a}");
    }
    eprintln!("fitting the nominal model and {} candidate effects", gap::EFFECTS.len() - gap::not_tested_count());
    let dx = diagnose(&data, &nominal, &DiagnoseOptions { holdout: args.holdout, ..DiagnoseOptions::default() })?;
    println!("gap before  held-out NRMSE {:.4} (averaged model, Cl {:.4} µF)", dx.gap_before.nrmse, dx.gap_before.cl * 1e6);
    println!("where       {}", dx.location.summary);
    for e in &dx.effects {
        let params: Vec<String> = e.params.iter().map(|(k, v)| format!("{k} = {v:.4e}")).collect();
        println!(
            "effect      {:18} NRMSE {:.4}  closes {:6.1} %  {}  Cl {:.4} µF  {}",
            e.name,
            e.nrmse_after,
            e.shrink_percent,
            if e.significant { "significant" } else { "not significant" },
            e.cl.estimate * 1e6,
            params.join(", ")
        );
    }
    for n in &dx.not_tested {
        println!("not tested  {:18} {}", n.name, n.reason);
    }
    println!("verdict     {}", dx.verdict);
    if let Some(path) = &args.json {
        std::fs::write(path, serde_json::to_string_pretty(&dx)? + "\n").with_context(|| format!("writing {}", path.display()))?;
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}
