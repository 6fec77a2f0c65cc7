//! Quantities with units, converted to the internal system: µm, nN, kPa (= nN/µm²), s,
//! radians.
//!
//! [`parse_quantity`] turns texts like `"500 Pa"`, `"0.2 um"` or `"24%"` into a number in
//! internal units. The newtypes [`Length`], [`Force`], [`Pressure`], [`Stiffness`], [`Time`],
//! [`Ratio`] and [`Angle`] use it to deserialise scenario files, so a bare number where a
//! unit is needed is rejected with a message that says what was expected.

use std::fmt;

/// Physical dimension a quantity must have.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Dimension {
    /// Length (internal unit µm).
    Length,
    /// Force (internal unit nN).
    Force,
    /// Pressure, stress or elastic modulus (internal unit kPa = nN/µm²).
    Pressure,
    /// Stiffness as force per length (internal unit nN/µm).
    Stiffness,
    /// Time (internal unit s).
    Time,
    /// Pure number (fractions, strains, Poisson's ratio); `%` allowed.
    Dimensionless,
    /// Angle (internal unit rad).
    Angle,
}

impl Dimension {
    /// Every dimension, in documentation order.
    pub const ALL: [Dimension; 7] = [
        Dimension::Length,
        Dimension::Force,
        Dimension::Pressure,
        Dimension::Stiffness,
        Dimension::Time,
        Dimension::Dimensionless,
        Dimension::Angle,
    ];

    /// Name with article, as used in messages ("a length").
    pub fn name(self) -> &'static str {
        match self {
            Dimension::Length => "a length",
            Dimension::Force => "a force",
            Dimension::Pressure => "a pressure",
            Dimension::Stiffness => "a stiffness",
            Dimension::Time => "a time",
            Dimension::Dimensionless => "a dimensionless number",
            Dimension::Angle => "an angle",
        }
    }

    /// An example of a valid text.
    pub fn example(self) -> &'static str {
        match self {
            Dimension::Length => "0.2 um",
            Dimension::Force => "2 nN",
            Dimension::Pressure => "500 Pa",
            Dimension::Stiffness => "50 pN/um",
            Dimension::Time => "10 s",
            Dimension::Dimensionless => "24%",
            Dimension::Angle => "90 deg",
        }
    }

    /// The internal unit's symbol (empty for dimensionless numbers).
    pub fn internal_unit(self) -> &'static str {
        match self {
            Dimension::Length => "um",
            Dimension::Force => "nN",
            Dimension::Pressure => "kPa",
            Dimension::Stiffness => "nN/um",
            Dimension::Time => "s",
            Dimension::Dimensionless => "",
            Dimension::Angle => "rad",
        }
    }

    /// The common unit symbols of this dimension, comma separated, for messages.
    pub fn common_units(self) -> &'static str {
        match self {
            Dimension::Length => "nm, um, µm, mm, m",
            Dimension::Force => "pN, nN, uN, mN, N",
            Dimension::Pressure => "Pa, kPa, MPa, GPa",
            Dimension::Stiffness => "pN/um, nN/um, uN/um, N/m",
            Dimension::Time => "us, ms, s, min, h",
            Dimension::Dimensionless => "%, or a bare number",
            Dimension::Angle => "deg, rad",
        }
    }
}

/// One accepted unit symbol.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Unit {
    /// The symbol as written after the number.
    pub symbol: &'static str,
    /// Its dimension.
    pub dimension: Dimension,
    /// Multiply a value in this unit by `factor` to get internal units.
    pub factor: f64,
}

/// Shorthand for the unit table.
const fn unit(symbol: &'static str, dimension: Dimension, factor: f64) -> Unit {
    Unit {
        symbol,
        dimension,
        factor,
    }
}

/// Every accepted unit symbol (case-sensitive). `µ` (micro sign), `μ` (Greek mu) and `u`
/// are all accepted for micro.
pub const UNITS: &[Unit] = &[
    unit("nm", Dimension::Length, 1e-3),
    unit("um", Dimension::Length, 1.0),
    unit("µm", Dimension::Length, 1.0),
    unit("μm", Dimension::Length, 1.0),
    unit("mm", Dimension::Length, 1e3),
    unit("cm", Dimension::Length, 1e4),
    unit("m", Dimension::Length, 1e6),
    unit("pN", Dimension::Force, 1e-3),
    unit("nN", Dimension::Force, 1.0),
    unit("uN", Dimension::Force, 1e3),
    unit("µN", Dimension::Force, 1e3),
    unit("μN", Dimension::Force, 1e3),
    unit("mN", Dimension::Force, 1e6),
    unit("N", Dimension::Force, 1e9),
    unit("Pa", Dimension::Pressure, 1e-3),
    unit("kPa", Dimension::Pressure, 1.0),
    unit("MPa", Dimension::Pressure, 1e3),
    unit("GPa", Dimension::Pressure, 1e6),
    unit("nN/um^2", Dimension::Pressure, 1.0),
    unit("nN/µm^2", Dimension::Pressure, 1.0),
    unit("nN/μm^2", Dimension::Pressure, 1.0),
    unit("pN/nm", Dimension::Stiffness, 1.0),
    unit("pN/um", Dimension::Stiffness, 1e-3),
    unit("pN/µm", Dimension::Stiffness, 1e-3),
    unit("pN/μm", Dimension::Stiffness, 1e-3),
    unit("nN/nm", Dimension::Stiffness, 1e3),
    unit("nN/um", Dimension::Stiffness, 1.0),
    unit("nN/µm", Dimension::Stiffness, 1.0),
    unit("nN/μm", Dimension::Stiffness, 1.0),
    unit("uN/um", Dimension::Stiffness, 1e3),
    unit("µN/µm", Dimension::Stiffness, 1e3),
    unit("μN/μm", Dimension::Stiffness, 1e3),
    unit("mN/m", Dimension::Stiffness, 1.0),
    unit("N/m", Dimension::Stiffness, 1e3),
    unit("us", Dimension::Time, 1e-6),
    unit("µs", Dimension::Time, 1e-6),
    unit("μs", Dimension::Time, 1e-6),
    unit("ms", Dimension::Time, 1e-3),
    unit("s", Dimension::Time, 1.0),
    unit("min", Dimension::Time, 60.0),
    unit("h", Dimension::Time, 3600.0),
    unit("%", Dimension::Dimensionless, 0.01),
    unit("rad", Dimension::Angle, 1.0),
    unit("deg", Dimension::Angle, std::f64::consts::PI / 180.0),
    unit("°", Dimension::Angle, std::f64::consts::PI / 180.0),
];

/// Why a quantity text could not be read.
#[derive(Debug, Clone, thiserror::Error, PartialEq)]
pub enum UnitError {
    /// The text is empty.
    #[error("expected {} with a unit, like \"{}\"; found an empty text", .expected.name(), .expected.example())]
    Empty {
        /// The dimension asked for.
        expected: Dimension,
    },
    /// The text does not start with a finite number.
    #[error("expected {} like \"{}\"; found \"{text}\", which does not start with a finite number", .expected.name(), .expected.example())]
    NotANumber {
        /// The dimension asked for.
        expected: Dimension,
        /// The text given.
        text: String,
    },
    /// A number without unit where a unit is required.
    #[error("expected {} with a unit, like \"{}\"; found the bare number {number}", .expected.name(), .expected.example())]
    MissingUnit {
        /// The dimension asked for.
        expected: Dimension,
        /// The number as written.
        number: String,
    },
    /// A known unit of another dimension.
    #[error("expected {} ({}); found \"{text}\", which is {}", .expected.name(), .expected.common_units(), .found.name())]
    WrongDimension {
        /// The dimension asked for.
        expected: Dimension,
        /// The dimension of the unit given.
        found: Dimension,
        /// The text given.
        text: String,
    },
    /// A unit symbol that is not in [`UNITS`].
    #[error("unknown unit \"{unit}\" in \"{text}\"; expected {} ({})", .expected.name(), .expected.common_units())]
    UnknownUnit {
        /// The dimension asked for.
        expected: Dimension,
        /// The unknown symbol.
        unit: String,
        /// The text given.
        text: String,
    },
}

/// Length of the leading decimal number (sign, digits, point, exponent) of `text`.
fn number_prefix_len(text: &str) -> usize {
    let b = text.as_bytes();
    let digits = |mut i: usize| {
        while i < b.len() && b[i].is_ascii_digit() {
            i += 1;
        }
        i
    };
    let mut i = usize::from(matches!(b.first(), Some(b'+' | b'-')));
    let int_end = digits(i);
    let mut end = int_end;
    if end < b.len() && b[end] == b'.' {
        end = digits(end + 1);
    }
    if end == i || (end == int_end + 1 && int_end == i) {
        return 0; // no digit at all
    }
    i = end;
    if i < b.len() && (b[i] == b'e' || b[i] == b'E') {
        let mut j = i + 1;
        if j < b.len() && (b[j] == b'+' || b[j] == b'-') {
            j += 1;
        }
        let exp_end = digits(j);
        if exp_end > j {
            end = exp_end;
        }
    }
    end
}

/// Looks up a unit symbol.
pub fn find_unit(symbol: &str) -> Option<&'static Unit> {
    UNITS.iter().find(|u| u.symbol == symbol)
}

/// Parses `text` as a quantity of dimension `dim` and returns it in internal units
/// (µm, nN, kPa, nN/µm, s, rad; fractions for dimensionless numbers).
///
/// A unit is required except for [`Dimension::Dimensionless`], where a bare number is the
/// value itself and `%` divides by 100. Space between number and unit is optional.
pub fn parse_quantity(text: &str, dim: Dimension) -> Result<f64, UnitError> {
    let trimmed = text.trim();
    if trimmed.is_empty() {
        return Err(UnitError::Empty { expected: dim });
    }
    let split = number_prefix_len(trimmed);
    let (number_text, unit_text) = (&trimmed[..split], trimmed[split..].trim());
    let not_a_number = || UnitError::NotANumber {
        expected: dim,
        text: trimmed.to_string(),
    };
    let number: f64 = number_text.parse().map_err(|_| not_a_number())?;
    if !number.is_finite() {
        return Err(not_a_number());
    }
    if unit_text.is_empty() {
        return match dim {
            Dimension::Dimensionless => Ok(number),
            _ => Err(UnitError::MissingUnit {
                expected: dim,
                number: number_text.to_string(),
            }),
        };
    }
    let unit = find_unit(unit_text).ok_or_else(|| UnitError::UnknownUnit {
        expected: dim,
        unit: unit_text.to_string(),
        text: trimmed.to_string(),
    })?;
    if unit.dimension != dim {
        return Err(UnitError::WrongDimension {
            expected: dim,
            found: unit.dimension,
            text: trimmed.to_string(),
        });
    }
    Ok(number * unit.factor)
}

/// Writes `value` (internal units) followed by the internal unit of `dim`. Rust's shortest
/// round-trip float formatting makes [`parse_quantity`] give back exactly `value`.
/// Very large or small magnitudes use exponent notation (`1e-20 um`).
pub fn format_quantity(value: f64, dim: Dimension) -> String {
    let magnitude = value.abs();
    let number = if magnitude == 0.0 || (1e-4..1e15).contains(&magnitude) {
        format!("{value}")
    } else {
        format!("{value:e}")
    };
    match dim.internal_unit() {
        "" => number,
        unit => format!("{number} {unit}"),
    }
}

/// Defines a serde newtype holding a value in internal units of one dimension.
macro_rules! quantity_type {
    ($(#[$doc:meta])* $name:ident, $dim:expr, accepts_bare_number: $bare:expr) => {
        $(#[$doc])*
        #[derive(Debug, Clone, Copy, PartialEq, PartialOrd, Default)]
        pub struct $name(pub f64);

        impl $name {
            /// The dimension of this quantity type.
            pub const DIMENSION: Dimension = $dim;
        }

        impl std::str::FromStr for $name {
            type Err = UnitError;

            fn from_str(text: &str) -> Result<Self, UnitError> {
                parse_quantity(text, $dim).map($name)
            }
        }

        impl fmt::Display for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str(&format_quantity(self.0, $dim))
            }
        }

        impl serde::Serialize for $name {
            fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
                if $bare {
                    serializer.serialize_f64(self.0)
                } else {
                    serializer.serialize_str(&format_quantity(self.0, $dim))
                }
            }
        }

        impl<'de> serde::Deserialize<'de> for $name {
            fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
                deserializer.deserialize_any(QuantityVisitor { dim: $dim, bare: $bare }).map($name)
            }
        }
    };
}

/// Serde visitor reading a quantity from a string, or from a number where allowed.
struct QuantityVisitor {
    dim: Dimension,
    bare: bool,
}

impl QuantityVisitor {
    /// Accepts a bare number only for dimensionless quantities.
    fn number<E: serde::de::Error>(&self, value: f64, written: String) -> Result<f64, E> {
        if self.bare {
            Ok(value)
        } else {
            Err(E::custom(UnitError::MissingUnit {
                expected: self.dim,
                number: written,
            }))
        }
    }
}

impl serde::de::Visitor<'_> for QuantityVisitor {
    type Value = f64;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} with a unit, like \"{}\"",
            self.dim.name(),
            self.dim.example()
        )
    }

    fn visit_str<E: serde::de::Error>(self, text: &str) -> Result<f64, E> {
        parse_quantity(text, self.dim).map_err(E::custom)
    }

    fn visit_f64<E: serde::de::Error>(self, value: f64) -> Result<f64, E> {
        self.number(value, format!("{value}"))
    }

    fn visit_i64<E: serde::de::Error>(self, value: i64) -> Result<f64, E> {
        self.number(value as f64, format!("{value}"))
    }

    fn visit_u64<E: serde::de::Error>(self, value: u64) -> Result<f64, E> {
        self.number(value as f64, format!("{value}"))
    }
}

quantity_type!(
    /// A length in µm; reads texts like `"0.2 um"`, `"7 nm"`.
    Length, Dimension::Length, accepts_bare_number: false
);
quantity_type!(
    /// A force in nN; reads texts like `"2 nN"`, `"50 pN"`.
    Force, Dimension::Force, accepts_bare_number: false
);
quantity_type!(
    /// A pressure, stress or modulus in kPa; reads texts like `"500 Pa"`, `"2.6 GPa"`.
    Pressure, Dimension::Pressure, accepts_bare_number: false
);
quantity_type!(
    /// A stiffness (force per length) in nN/µm; reads texts like `"50 pN/um"`.
    Stiffness, Dimension::Stiffness, accepts_bare_number: false
);
quantity_type!(
    /// A time in s; reads texts like `"10 s"`, `"1 ms"`.
    Time, Dimension::Time, accepts_bare_number: false
);
quantity_type!(
    /// A dimensionless ratio; reads bare numbers (`0.24`) or percentages (`"24%"`), and is
    /// written as a bare number.
    Ratio, Dimension::Dimensionless, accepts_bare_number: true
);
quantity_type!(
    /// An angle in radians; reads texts like `"90 deg"`, `"1.57 rad"`.
    Angle, Dimension::Angle, accepts_bare_number: false
);

impl fmt::Display for Dimension {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-12 * b.abs().max(1e-300)
    }

    #[test]
    fn accepts_the_documented_examples() {
        let cases: &[(&str, Dimension, f64)] = &[
            ("500 Pa", Dimension::Pressure, 0.5),
            ("0.5 kPa", Dimension::Pressure, 0.5),
            ("2.6 GPa", Dimension::Pressure, 2.6e6),
            ("1 MPa", Dimension::Pressure, 1e3),
            ("7 nm", Dimension::Length, 0.007),
            ("0.2 um", Dimension::Length, 0.2),
            ("0.2 µm", Dimension::Length, 0.2),
            ("0.2 μm", Dimension::Length, 0.2),
            ("32.264um", Dimension::Length, 32.264),
            ("1e-3 mm", Dimension::Length, 1.0),
            ("  -4.5E+1 nm ", Dimension::Length, -0.045),
            ("2 nN", Dimension::Force, 2.0),
            ("1 pN", Dimension::Force, 1e-3),
            ("1 uN", Dimension::Force, 1e3),
            ("0.5 N", Dimension::Force, 5e8),
            ("10 s", Dimension::Time, 10.0),
            ("1 ms", Dimension::Time, 1e-3),
            ("2 min", Dimension::Time, 120.0),
            ("24 %", Dimension::Dimensionless, 0.24),
            ("24%", Dimension::Dimensionless, 0.24),
            ("0.24", Dimension::Dimensionless, 0.24),
            ("90 deg", Dimension::Angle, PI / 2.0),
            ("1.57 rad", Dimension::Angle, 1.57),
            ("50 pN/um", Dimension::Stiffness, 0.05),
            ("1 N/m", Dimension::Stiffness, 1e3),
            (".5 nN/um", Dimension::Stiffness, 0.5),
        ];
        for &(text, dim, expected) in cases {
            let got = parse_quantity(text, dim).unwrap_or_else(|e| panic!("{text}: {e}"));
            assert!(
                close(got, expected),
                "{text}: got {got}, expected {expected}"
            );
        }
    }

    #[test]
    fn unit_table_is_consistent() {
        for (i, u) in UNITS.iter().enumerate() {
            assert!(
                UNITS[i + 1..].iter().all(|v| v.symbol != u.symbol),
                "{} twice",
                u.symbol
            );
            assert!(u.factor > 0.0 && u.factor.is_finite());
            let value = parse_quantity(&format!("1 {}", u.symbol), u.dimension).unwrap();
            assert_eq!(value, u.factor, "{}", u.symbol);
        }
        for dim in Dimension::ALL {
            if dim != Dimension::Dimensionless {
                assert_eq!(find_unit(dim.internal_unit()).unwrap().factor, 1.0, "{dim}");
            }
            assert!(parse_quantity(dim.example(), dim).is_ok(), "{dim}");
        }
    }

    #[test]
    fn errors_say_what_was_expected_and_found() {
        let msg = |text: &str, dim| parse_quantity(text, dim).unwrap_err().to_string();
        assert_eq!(
            msg("0.2", Dimension::Length),
            "expected a length with a unit, like \"0.2 um\"; found the bare number 0.2"
        );
        assert_eq!(
            msg("7 nm", Dimension::Pressure),
            "expected a pressure (Pa, kPa, MPa, GPa); found \"7 nm\", which is a length"
        );
        let unknown = msg("3 furlong", Dimension::Length);
        assert!(unknown.contains("unknown unit \"furlong\""), "{unknown}");
        assert!(unknown.contains("nm, um, µm, mm, m"), "{unknown}");
        assert!(msg("abc", Dimension::Force).contains("does not start with a finite number"));
        assert!(msg("inf nN", Dimension::Force).contains("finite number"));
        assert!(msg(".", Dimension::Force).contains("finite number"));
        assert!(msg("1e999 nN", Dimension::Force).contains("finite number"));
        assert!(msg("", Dimension::Time).contains("empty"));
        assert!(msg("90", Dimension::Angle).contains("expected an angle with a unit"));
        assert!(msg("24 %", Dimension::Length).contains("which is a dimensionless number"));
        assert!(msg("1 kpa", Dimension::Pressure).contains("unknown unit \"kpa\""));
    }

    #[test]
    fn formatting_then_parsing_round_trips() {
        // Property-style check over many magnitudes and signs, seeded for reproducibility.
        let mut rng = cellmech_fem::mesh::generate::SplitMix64::new(2024);
        for _ in 0..2000 {
            let exponent = rng.uniform(-30.0, 30.0);
            let sign = if rng.next_f64() < 0.5 { -1.0 } else { 1.0 };
            let value = sign * rng.uniform(1.0, 10.0) * 10f64.powf(exponent);
            for dim in Dimension::ALL {
                let text = format_quantity(value, dim);
                assert_eq!(parse_quantity(&text, dim), Ok(value), "{text}");
            }
            assert_eq!(
                Length(value).to_string().parse::<Length>(),
                Ok(Length(value))
            );
            assert_eq!(Ratio(value).to_string().parse::<Ratio>(), Ok(Ratio(value)));
        }
        assert_eq!(Length(0.2).to_string(), "0.2 um");
        assert_eq!(Pressure(2.6e6).to_string(), "2600000 kPa");
        assert_eq!(Length(1e-20).to_string(), "1e-20 um");
        assert_eq!(Ratio(0.24).to_string(), "0.24");
        assert_eq!(Angle(PI).to_string(), format!("{PI} rad"));
    }

    #[derive(Debug, PartialEq, serde::Deserialize, serde::Serialize)]
    struct Sample {
        radius: Length,
        modulus: Pressure,
        prestrain: Ratio,
        force: Force,
        spring: Stiffness,
        duration: Time,
        tilt: Angle,
    }

    const SAMPLE: &str = r#"
radius = "16.132 um"
modulus = "500 Pa"
prestrain = "24%"
force = "2 nN"
spring = "50 pN/um"
duration = "1 ms"
tilt = "90 deg"
"#;

    #[test]
    fn toml_reads_quantities_and_writes_internal_units() {
        let s: Sample = toml::from_str(SAMPLE).unwrap();
        assert_eq!(s.radius, Length(16.132));
        assert_eq!(s.modulus, Pressure(0.5));
        assert!(close(s.prestrain.0, 0.24));
        assert_eq!(
            (s.force, s.spring, s.duration),
            (Force(2.0), Stiffness(0.05), Time(1e-3))
        );
        assert!(close(s.tilt.0, PI / 2.0));
        let bare: Sample = toml::from_str(&SAMPLE.replace("\"24%\"", "0.24")).unwrap();
        assert_eq!(bare.prestrain, Ratio(0.24));
        let written = toml::to_string(&s).unwrap();
        assert!(written.contains("radius = \"16.132 um\""), "{written}");
        assert!(written.contains("modulus = \"0.5 kPa\""), "{written}");
        assert!(written.contains("prestrain = 0.24"), "{written}");
        assert_eq!(toml::from_str::<Sample>(&written).unwrap(), s);
    }

    #[test]
    fn toml_errors_carry_line_and_expected_unit() {
        let text = SAMPLE.replace("\"500 Pa\"", "500");
        let err = toml::from_str::<Sample>(&text).unwrap_err().to_string();
        assert!(err.contains("line 3"), "{err}");
        assert!(
            err.contains(
                "expected a pressure with a unit, like \"500 Pa\"; found the bare number 500"
            ),
            "{err}"
        );
        let text = SAMPLE.replace("\"16.132 um\"", "\"16.132 kPa\"");
        let err = toml::from_str::<Sample>(&text).unwrap_err().to_string();
        assert!(err.contains("line 2"), "{err}");
        assert!(err.contains("which is a pressure"), "{err}");
        let text = SAMPLE.replace("\"1 ms\"", "1.5");
        let err = toml::from_str::<Sample>(&text).unwrap_err().to_string();
        assert!(
            err.contains("line 7") && err.contains("found the bare number 1.5"),
            "{err}"
        );
    }
}
