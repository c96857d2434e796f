//! The IHO S-44 statement of `iho.json` (written by `lidarqa qc` with an `iho-s44` standard).

use crate::products::*;
use crate::text::{esc, meaning};
use std::fmt::Write as _;

pub(super) fn iho_section(i: &Iho) -> String {
    let mut o = String::new();
    o.push_str("<table id=\"iho\"><caption>IHO S-44 orders: share of soundings within the allowed total horizontal and vertical uncertainty (THU and TVU, 95 %)</caption><thead><tr><th>order</th><th>soundings meeting (%)</th><th class=\"text\">verdict</th></tr></thead><tbody>\n");
    for ord in &i.orders {
        let ok = ord.percent_meeting >= 95.0;
        let _ = writeln!(
            o,
            "<tr><td>{}</td><td>{:.1}</td><td class=\"text {}\">{}</td></tr>",
            esc(&ord.order),
            ord.percent_meeting,
            if ok { "ok" } else { "fail" },
            if ok { "meets" } else { "does not meet" }
        );
    }
    o.push_str("</tbody></table>\n");
    for ord in i.orders.iter().filter(|o| !o.by_depth.is_empty()) {
        let _ = writeln!(
            o,
            "<table><caption>Order {} by depth</caption><thead><tr><th>depth (m)</th><th>soundings</th><th>meeting (%)</th></tr></thead><tbody>",
            esc(&ord.order)
        );
        for b in &ord.by_depth {
            let _ = writeln!(
                o,
                "<tr><td>{:.1} – {:.1}</td><td>{}</td><td>{:.1}</td></tr>",
                b.depth_min_m,
                b.depth_max_m,
                b.n.map(|n| n.to_string()).unwrap_or_else(|| "—".into()),
                b.percent_meeting
            );
        }
        o.push_str("</tbody></table>\n");
    }
    let best = i
        .orders
        .iter()
        .filter(|o| o.percent_meeting >= 95.0)
        .map(|o| o.order.as_str())
        .next();
    let text = match best {
        Some(b) => format!("The survey meets IHO S-44 Order {} for the uncertainty of its soundings: at least 95 % of them are within that order's THU and TVU.", esc(b)),
        None => "The survey meets none of the IHO S-44 orders listed for the uncertainty of its soundings: fewer than 95 % of them are within each order's THU and TVU.".into(),
    };
    meaning(&mut o, &text);
    o
}
