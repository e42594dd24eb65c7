//! The STM32 boards' audio clock plans as the register values the boards write, and the rates
//! they give (host tested: the ADCs' sample rate must be 16 kHz ± 0.1 %).
//!
//! * STM32F411CE (`boards/f411.rs`): HSE → PLLI2S (RCC_PLLI2SCFGR: PLLI2SM, PLLI2SN, PLLI2SR) → I2S
//!   kernel clock → SPI2_I2SPR (I2SDIV, ODD, MCKOE) → MCK, with 32-bit channels (64 bit clocks
//!   per frame). RM0383, SPI/I2S chapter, "Clock generator": with MCKOE = 1,
//!   Fs = I2SxCLK / (256 × (2 × I2SDIV + ODD)); MCK = 256 Fs.
//! * STM32F446RE (`boards/f446.rs`): HSE → PLLSAI (RCC_PLLSAICFGR: PLLSAIM, PLLSAIN, PLLSAIQ) →
//!   RCC_DCKCFGR.PLLSAIDIVQ → SAI1 kernel clock → SAI_xCR1.MCKDIV → MCLK; with NODIV = 0 the SAI
//!   has MCLK = 256 FS and SCK = MCLK × (FRL + 1) / 256 (RM0390 §28.3.8, "SAI clock generator":
//!   MCLK_x = sai_x_ker_ck / (MCKDIV × 2) for MCKDIV ≠ 0; Table 174 lists MCKDIV = 0110 for
//!   16 kHz from 256 × 192 kHz).
//!
//! The `MCKDIV` field is the register's 4-bit value, not the division: stm32-metapac 21's
//! `sai::vals::Mckdiv` names the division (`DIV12 = 0x06`, `DIV6 = 0x03`), so the board converts
//! the field value with `Mckdiv::from_bits`.

/// The STM32F411CE board's I2S clock plan (register field values).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct I2sClockPlan {
    /// HSE crystal, Hz.
    pub hse_hz: u32,
    /// RCC_PLLI2SCFGR.PLLI2SM (input divider; the F411 has its own for PLLI2S).
    pub plli2s_m: u8,
    /// RCC_PLLI2SCFGR.PLLI2SN (VCO multiplier).
    pub plli2s_n: u16,
    /// RCC_PLLI2SCFGR.PLLI2SR (I2S kernel clock divider).
    pub plli2s_r: u8,
    /// SPI_I2SPR.I2SDIV.
    pub i2sdiv: u8,
    /// SPI_I2SPR.ODD.
    pub odd: bool,
    /// SPI_I2SPR.MCKOE (master clock output on).
    pub mckoe: bool,
    /// Bit clocks per frame: 2 channels × 32 bits (SPI_I2SCFGR.CHLEN = 1).
    pub frame_bits: u32,
}

/// The STM32F411CE board: HSE 25 MHz / 25 × 258 / 3 = 86 MHz I2S clock; I2SDIV 10, ODD 1 (÷ 21),
/// MCKOE → MCK 4.0952 MHz, fs 15 997 Hz, BCK 64 fs = 1.0238 MHz.
pub const F411_I2S: I2sClockPlan = I2sClockPlan {
    hse_hz: 25_000_000,
    plli2s_m: 25,
    plli2s_n: 258,
    plli2s_r: 3,
    i2sdiv: 10,
    odd: true,
    mckoe: true,
    frame_bits: 64,
};

impl I2sClockPlan {
    /// The I2S kernel clock (PLLI2S R output), Hz.
    #[must_use]
    pub const fn kernel_hz(&self) -> f64 {
        self.hse_hz as f64 / self.plli2s_m as f64 * self.plli2s_n as f64 / self.plli2s_r as f64
    }

    /// The I2S prescaler's division: 2 × I2SDIV + ODD.
    #[must_use]
    pub const fn division(&self) -> u32 {
        2 * self.i2sdiv as u32 + self.odd as u32
    }

    /// The sample rate (WS), Hz: kernel / (256 × division) with MCKOE, else
    /// kernel / (frame bits × division) (RM0383, I2S clock generator).
    #[must_use]
    pub fn sample_rate_hz(&self) -> f64 {
        let per_frame = if self.mckoe { 256 } else { self.frame_bits };
        self.kernel_hz() / (per_frame as f64 * self.division() as f64)
    }

    /// The master clock (MCK), Hz: 256 fs.
    #[must_use]
    pub fn master_clock_hz(&self) -> f64 {
        256.0 * self.sample_rate_hz()
    }

    /// The bit clock (CK), Hz.
    #[must_use]
    pub fn bit_clock_hz(&self) -> f64 {
        self.frame_bits as f64 * self.sample_rate_hz()
    }
}

/// The prescaler embassy-stm32 0.6 computes for an I2S master (`i2s.rs`, `compute_baud_rate`):
/// division = round(kernel / (coefficient × fs)), coefficient 256 with the master clock output,
/// else 64 for 32-bit channels; returned as `(ODD, I2SDIV)`. The board checks the value it reads
/// back from SPI_I2SPR against the plan; this is the same computation for the host test.
#[must_use]
pub const fn embassy_i2s_prescaler(kernel_hz: u32, fs_hz: u32, mckoe: bool) -> (bool, u8) {
    let coefficient = if mckoe { 256 } else { 64 };
    let d = coefficient * fs_hz;
    let division = (kernel_hz + d / 2) / d;
    if division < 4 {
        (false, 2)
    } else if division > 511 {
        (true, 255)
    } else {
        (division & 1 == 1, (division >> 1) as u8)
    }
}

/// The STM32F446RE board's SAI clock plan (register field values).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SaiClockPlan {
    /// HSE (the ST-LINK's MCO), Hz.
    pub hse_hz: u32,
    /// RCC_PLLSAICFGR.PLLSAIM.
    pub pllsai_m: u8,
    /// RCC_PLLSAICFGR.PLLSAIN.
    pub pllsai_n: u16,
    /// RCC_PLLSAICFGR.PLLSAIQ.
    pub pllsai_q: u8,
    /// The division RCC_DCKCFGR.PLLSAIDIVQ selects (field value + 1).
    pub pllsai_div_q: u8,
    /// SAI_xCR1.MCKDIV, the 4-bit field value (MCLK = kernel / (2 × MCKDIV), MCKDIV ≠ 0).
    pub mckdiv: u8,
    /// SAI_xCR1.NODIV (0: MCLK = 256 FS).
    pub nodiv: bool,
    /// Bit clocks per frame, FRL + 1 (SAI_xFRCR.FRL holds one less).
    pub frame_bits: u32,
}

/// The STM32F446RE board: HSE 8 MHz / 4 × 172 / 7 / 1 = 49.1429 MHz SAI clock; MCKDIV field 6
/// (÷ 12) → MCLK 4.0952 MHz = 256 FS, FS 15 997 Hz; 128-bit frames → SCK 2.0476 MHz.
pub const F446_SAI: SaiClockPlan = SaiClockPlan {
    hse_hz: 8_000_000,
    pllsai_m: 4,
    pllsai_n: 172,
    pllsai_q: 7,
    pllsai_div_q: 1,
    mckdiv: 6,
    nodiv: false,
    frame_bits: 128,
};

impl SaiClockPlan {
    /// The SAI kernel clock, Hz.
    #[must_use]
    pub fn kernel_hz(&self) -> f64 {
        self.hse_hz as f64 / f64::from(self.pllsai_m) * f64::from(self.pllsai_n)
            / f64::from(self.pllsai_q)
            / f64::from(self.pllsai_div_q)
    }

    /// The master clock MCLK, Hz (RM0390 §28.3.8).
    #[must_use]
    pub fn master_clock_hz(&self) -> f64 {
        if self.mckdiv == 0 {
            self.kernel_hz()
        } else {
            self.kernel_hz() / (2.0 * f64::from(self.mckdiv))
        }
    }

    /// The frame sync rate FS, Hz: MCLK / 256 with NODIV = 0; with NODIV = 1 the kernel clock is
    /// the bit clock and FS = kernel / (FRL + 1).
    #[must_use]
    pub fn sample_rate_hz(&self) -> f64 {
        if self.nodiv {
            self.kernel_hz() / self.frame_bits as f64
        } else {
            self.master_clock_hz() / 256.0
        }
    }

    /// The bit clock SCK, Hz.
    #[must_use]
    pub fn bit_clock_hz(&self) -> f64 {
        self.frame_bits as f64 * self.sample_rate_hz()
    }
}

/// The STM32F4's LSI, the independent watchdog's clock, Hz (nominal; 17–47 kHz over parts and
/// temperature, datasheets' LSI characteristics).
pub const LSI_HZ: u32 = 32_000;

/// IWDG_PR (prescaler field: ÷ 4 · 2^PR) and IWDG_RLR (12-bit reload) for a timeout of at least
/// `timeout_us` at the nominal LSI: the smallest prescaler whose reload reaches it (RM0383, IWDG:
/// timeout = 4 · 2^PR · (RL + 1) / LSI); `None` beyond ÷ 256 × 4096 (32.8 s).
#[must_use]
pub const fn iwdg_setting(timeout_us: u32) -> Option<(u8, u16)> {
    let mut pr = 0;
    while pr <= 6 {
        let divider = 4u64 << pr;
        let ticks = (timeout_us as u64 * LSI_HZ as u64).div_ceil(divider * 1_000_000);
        if ticks <= 4096 {
            let reload = if ticks == 0 { 0 } else { ticks - 1 };
            return Some((pr as u8, reload as u16));
        }
        pr += 1;
    }
    None
}

/// The IWDG timeout, µs, of prescaler field `pr` and reload `rl` at the nominal LSI.
#[must_use]
pub const fn iwdg_timeout_us(pr: u8, rl: u16) -> u64 {
    (4u64 << pr) * (rl as u64 + 1) * 1_000_000 / LSI_HZ as u64
}

/// Whether `rate_hz` is within ± 0.1 % of `nominal_hz`.
#[must_use]
pub fn within_tolerance(rate_hz: f64, nominal_hz: u32) -> bool {
    (rate_hz / f64::from(nominal_hz) - 1.0).abs() <= 1e-3
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::board_api::SAMPLE_RATE_HZ;

    #[test]
    fn f411_plan_gives_16_khz_at_the_adcs() {
        let p = F411_I2S;
        assert!((p.kernel_hz() - 86e6).abs() < 1.0);
        // VCO input 1 MHz and VCO 258 MHz (RM0383 RCC_PLLI2SCFGR: 1–2 MHz recommended input,
        // 100–432 MHz VCO); I2S clock ≤ 192 MHz.
        let vco_in = f64::from(p.hse_hz) / f64::from(p.plli2s_m);
        assert!((0.95e6..=2.1e6).contains(&vco_in));
        assert!((100e6..=432e6).contains(&(vco_in * f64::from(p.plli2s_n))));
        assert!(
            within_tolerance(p.sample_rate_hz(), SAMPLE_RATE_HZ),
            "{}",
            p.sample_rate_hz()
        );
        // The PCM1808 wants SCKI = 256 fs and BCK = 64 fs.
        assert!((p.master_clock_hz() / p.sample_rate_hz() - 256.0).abs() < 1e-9);
        assert!((p.bit_clock_hz() - 1.0238e6).abs() < 100.0);
        // The prescaler in the plan is the one embassy writes for this kernel clock and rate.
        assert_eq!(
            embassy_i2s_prescaler(p.kernel_hz() as u32, SAMPLE_RATE_HZ, p.mckoe),
            (p.odd, p.i2sdiv)
        );
    }

    #[test]
    fn f446_plan_gives_16_khz_at_the_adc() {
        let p = F446_SAI;
        let vco_in = f64::from(p.hse_hz) / f64::from(p.pllsai_m);
        assert!((0.95e6..=2.1e6).contains(&vco_in));
        assert!((100e6..=432e6).contains(&(vco_in * f64::from(p.pllsai_n))));
        assert!(
            within_tolerance(p.sample_rate_hz(), SAMPLE_RATE_HZ),
            "{}",
            p.sample_rate_hz()
        );
        // SCK = MCLK × (FRL + 1) / 256 (RM0390 §28.3.8) gives the same bit clock.
        let sck = p.master_clock_hz() * p.frame_bits as f64 / 256.0;
        assert!((sck - p.bit_clock_hz()).abs() < 1e-3);
        assert!((p.bit_clock_hz() - 2.0476e6).abs() < 100.0);
        // With NODIV = 0 the frame length must be a power of two (RM0390 §28.3.8).
        assert!(p.frame_bits.is_power_of_two() && !p.nodiv);
        // One frame of the plan is one TDM frame of 4 slots of 32 bits.
        assert_eq!(p.frame_bits, crate::tdm::FRAME_BITS);
    }

    #[test]
    fn watchdog_settings_reach_the_timeouts() {
        for timeout in [
            250_000,
            1_000_000,
            crate::board_api::ERASE_WATCHDOG_TIMEOUT_US,
        ] {
            let (pr, rl) = iwdg_setting(timeout).unwrap();
            let got = iwdg_timeout_us(pr, rl);
            assert!(
                got >= u64::from(timeout) && got < u64::from(timeout) + 8_000,
                "{timeout}: {got}"
            );
            assert!(pr <= 6 && rl <= 0xFFF);
        }
        assert_eq!(iwdg_setting(250_000), Some((0, 1999)));
        // Even at the fastest LSI (47 kHz) the erase timeout outlasts a 4 s sector erase.
        let (pr, rl) = iwdg_setting(crate::board_api::ERASE_WATCHDOG_TIMEOUT_US).unwrap();
        assert!(iwdg_timeout_us(pr, rl) * u64::from(LSI_HZ) / 47_000 > 4_000_000);
        assert_eq!(iwdg_setting(40_000_000), None);
    }

    #[test]
    fn mckdiv_is_a_field_value_not_a_division() {
        // The field value 3 (metapac's `Mckdiv::DIV6`) divides by 6: the ADC runs at 32 kHz.
        let div6 = SaiClockPlan {
            mckdiv: 3,
            ..F446_SAI
        };
        assert!((div6.sample_rate_hz() / 31_994.0 - 1.0).abs() < 1e-3);
        assert!(!within_tolerance(div6.sample_rate_hz(), SAMPLE_RATE_HZ));
    }
}
