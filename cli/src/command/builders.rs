//! `cellbih builders`: every builder of the registry, what it is, and the
//! knobs its table declares (in 80 columns).

use cellbih::registry::BuilderKind;

use crate::Res;

/// Runs `cellbih builders`.
pub fn run() -> Res<()> {
    // 80 columns: each builder's name, what it is (indented 4),
    // then its knobs (`  --name`, their help indented 6).
    let wrapped = |indent: usize, text: &str| {
        let pad = " ".repeat(indent);
        let body = crate::report::wrap(text, 80 - indent);
        format!("{pad}{}", body.replace('\n', &format!("\n{pad}")))
    };
    for b in BuilderKind::ALL {
        let q = b.quality();
        let knobs = match (q.binned_sah, q.empty_cut) {
            (true, true) => "; builds --split sah and --empty-cut",
            (false, true) => "; builds --empty-cut",
            (true, false) => "; builds --split sah",
            (false, false) => "",
        };
        println!("{}", b.name());
        println!("{}", wrapped(4, &format!("{}{knobs}", b.describe())));
        for k in b.knobs() {
            let range = match k.is_flag() {
                true => String::new(),
                false => format!(" ({}; default {})", k.range(), k.default_text()),
            };
            println!("  --{}", k.name);
            println!("{}", wrapped(6, &format!("{}{range}", k.help)));
        }
    }
    Ok(())
}
