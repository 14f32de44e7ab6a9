//! The Embree device: creation, the version check, and Embree's errors turned into `Result`s.

use std::cell::{Cell, RefCell};
use std::ffi::{CStr, CString, c_char, c_void};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::ptr;
use std::sync::Arc;

use super::{Error, sys};

thread_local! {
    // Embree reports an error on the thread whose API call failed, through the device's error
    // function: it lands here, and the wrapper turns it into an `Err` when that call returns.
    static ERROR_CODE: Cell<sys::RTCError> = const { Cell::new(sys::RTC_ERROR_NONE) };
    static ERROR_MESSAGE: RefCell<String> = const { RefCell::new(String::new()) };
}

/// The device's error function: keeps the first error since the last check. Never panics
/// (a panic must not unwind into Embree) and never prints.
unsafe extern "C" fn error_function(_user: *mut c_void, code: sys::RTCError, message: *const c_char) {
    let _ = catch_unwind(AssertUnwindSafe(|| {
        let text = if message.is_null() {
            String::new()
        } else {
            // SAFETY: Embree passes a NUL-terminated string that lives for this call.
            unsafe { CStr::from_ptr(message) }.to_string_lossy().into_owned()
        };
        let _ = ERROR_CODE.try_with(|c| {
            if c.get() == sys::RTC_ERROR_NONE {
                c.set(code);
                let _ = ERROR_MESSAGE.try_with(|m| m.replace(text));
            }
        });
    }));
}

/// The error Embree reported on this thread since the last call, if any, as an `Err` naming
/// the API function that failed. Inlined down to one thread-local load and a compare: it
/// runs after every query; the error path is [`reported_error`], out of line.
#[inline]
pub(crate) fn take_error(call: &'static str) -> Result<(), Error> {
    if ERROR_CODE.with(|c| c.get()) == sys::RTC_ERROR_NONE {
        return Ok(());
    }
    reported_error(call)
}

#[cold]
#[inline(never)]
fn reported_error(call: &'static str) -> Result<(), Error> {
    let code = ERROR_CODE.with(|c| c.replace(sys::RTC_ERROR_NONE));
    let message = ERROR_MESSAGE.with(|m| m.take());
    Err(Error::Api { call, code, message })
}

/// How to create a [`Device`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DeviceOptions {
    /// Threads Embree may use to build BVHs; `None` uses every core.
    pub threads: Option<usize>,
}

/// An Embree device. Cheap to clone (reference counted); released when the last clone and
/// every scene made from it are gone.
#[derive(Clone)]
pub struct Device {
    inner: Arc<RawDevice>,
}

struct RawDevice(sys::RTCDevice);

// SAFETY: an Embree device may be used from any thread: its API calls are thread-safe, and it
// is released once, by the last owner, in `Drop`.
unsafe impl Send for RawDevice {}
// SAFETY: as above; `&RawDevice` only hands the handle to Embree's thread-safe API.
unsafe impl Sync for RawDevice {}

impl Drop for RawDevice {
    fn drop(&mut self) {
        // SAFETY: the handle came from `rtcNewDevice`, is non-null, and this is its only release.
        unsafe { sys::rtcReleaseDevice(self.0) };
    }
}

impl std::fmt::Debug for Device {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "embree::Device({})", version_string(self.version()))
    }
}

fn version_string(v: u32) -> String {
    format!("{}.{}.{}", v / 10000, v / 100 % 100, v % 100)
}

impl Device {
    /// A device with Embree's default configuration (as many build threads as cores).
    pub fn new() -> Result<Device, Error> {
        Device::with_options(DeviceOptions::default())
    }

    /// A device with the given options.
    ///
    /// Fails if Embree cannot create it, or if the library's version does not match the
    /// headers strahl was built against (their structs could differ in size).
    pub fn with_options(options: DeviceOptions) -> Result<Device, Error> {
        // Only settings strahl composes itself reach Embree's configuration parser: it loops
        // forever on some malformed strings (seen with `isa=bogus` in 3.13.5).
        let config = match options.threads {
            Some(n) => format!("threads={n}"),
            None => String::new(),
        };
        let c_config = CString::new(config.clone()).map_err(|_| Error::InvalidInput {
            object: "Embree configuration".into(),
            problem: "contains a NUL byte".into(),
        })?;
        // SAFETY: `c_config` is a valid NUL-terminated string for the duration of the call.
        let raw = unsafe { sys::rtcNewDevice(c_config.as_ptr()) };
        if raw.is_null() {
            // SAFETY: a NULL device asks for the error of the last failed `rtcNewDevice` on this
            // thread, which is what Embree documents for this case.
            let code = unsafe { sys::rtcGetDeviceError(ptr::null_mut()) };
            return Err(Error::Api {
                call: "rtcNewDevice",
                code,
                message: format!("cannot create a device with configuration {config:?}"),
            });
        }
        let device = Device { inner: Arc::new(RawDevice(raw)) };
        // SAFETY: `raw` is a live device; the function is `extern "C"`, catches every panic
        // and uses no user pointer.
        unsafe { sys::rtcSetDeviceErrorFunction(raw, Some(error_function), ptr::null_mut()) };
        take_error("rtcSetDeviceErrorFunction")?;
        device.check_version()?;
        Ok(device)
    }

    /// `RTC_DEVICE_PROPERTY_VERSION` of the loaded library, e.g. 31305 for 3.13.5.
    pub fn version(&self) -> u32 {
        // SAFETY: the device is live; the property is a plain integer query.
        unsafe { sys::rtcGetDeviceProperty(self.raw(), sys::RTC_DEVICE_PROPERTY_VERSION) as u32 }
    }

    /// The library's version as `major.minor.patch`, e.g. `3.13.5`.
    pub fn version_string(&self) -> String {
        version_string(self.version())
    }

    /// The widest ray packet the library traces natively on this CPU: 16 means Embree runs
    /// its AVX-512 kernels, 8 AVX/AVX2, 4 SSE (`RTC_DEVICE_PROPERTY_NATIVE_RAY{4,8,16}_SUPPORTED`;
    /// Embree picks the best ISA it was built for that the CPU has).
    pub fn native_packet_width(&self) -> u32 {
        let supported = |property| {
            // SAFETY: the device is live; the property is a plain integer query.
            unsafe { sys::rtcGetDeviceProperty(self.raw(), property) != 0 }
        };
        if supported(sys::RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED) {
            16
        } else if supported(sys::RTC_DEVICE_PROPERTY_NATIVE_RAY8_SUPPORTED) {
            8
        } else if supported(sys::RTC_DEVICE_PROPERTY_NATIVE_RAY4_SUPPORTED) {
            4
        } else {
            1
        }
    }

    /// One line for reports and `strahl --version`: the library's version, the headers' when
    /// they differ in the patch level, and the instruction set Embree traces with, e.g.
    /// `Embree 3.13.5 (ISA AVX-512: native 16-wide packets)`.
    pub fn describe(&self) -> String {
        let width = self.native_packet_width();
        let isa = match width {
            16 => "AVX-512",
            8 if cpu_has_avx2() => "AVX2",
            8 => "AVX",
            4 => "SSE",
            _ => "scalar",
        };
        let (library, headers) = (self.version(), Self::header_version());
        let built = if library == headers { String::new() } else { format!(", headers {}", version_string(headers)) };
        format!("Embree {}{built} (ISA {isa}: native {width}-wide packets)", version_string(library))
    }

    /// `RTC_VERSION` of the headers the bindings were generated from.
    pub fn header_version() -> u32 {
        sys::RTC_VERSION
    }

    /// Refuses a library whose major or minor version differs from the headers': structs such
    /// as `RTCRayHit` change size between such releases, and Embree would then write past the
    /// end of ours.
    fn check_version(&self) -> Result<(), Error> {
        let (library, headers) = (self.version(), Self::header_version());
        if library / 100 != headers / 100 {
            return Err(Error::VersionMismatch { library: version_string(library), headers: version_string(headers) });
        }
        Ok(())
    }

    pub(crate) fn raw(&self) -> sys::RTCDevice {
        self.inner.0
    }
}

/// Whether the CPU has AVX2 (to tell Embree's AVX and AVX2 kernels apart in [`Device::describe`]).
fn cpu_has_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    return std::arch::is_x86_feature_detected!("avx2");
    #[cfg(not(target_arch = "x86_64"))]
    false
}

/// Asks the calling thread's SSE unit to flush denormal results to zero and treat denormal
/// inputs as zero (MXCSR bits FTZ 0x8000 and DAZ 0x0040), as Embree's documentation asks of
/// every thread that traces. Call it once in each worker thread (e.g. in rayon's
/// `start_handler`); it only affects the calling thread.
pub fn enable_flush_to_zero() {
    #[cfg(target_arch = "x86_64")]
    {
        let mut csr: u32 = 0;
        // SAFETY: `stmxcsr`/`ldmxcsr` read and write this thread's MXCSR through a valid,
        // aligned local; setting FTZ and DAZ changes only how denormals round.
        unsafe {
            std::arch::asm!("stmxcsr [{}]", in(reg) &mut csr, options(nostack, preserves_flags));
            csr |= 0x8040;
            std::arch::asm!("ldmxcsr [{}]", in(reg) &csr, options(nostack, preserves_flags));
        }
    }
}

/// Whether this thread flushes denormals to zero (always `true` off x86-64, where the call
/// above does nothing).
pub fn flush_to_zero_enabled() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        let mut csr: u32 = 0;
        // SAFETY: `stmxcsr` stores this thread's MXCSR into a valid, aligned local.
        unsafe { std::arch::asm!("stmxcsr [{}]", in(reg) &mut csr, options(nostack, preserves_flags)) };
        csr & 0x8040 == 0x8040
    }
    #[cfg(not(target_arch = "x86_64"))]
    true
}
